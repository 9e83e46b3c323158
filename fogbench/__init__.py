"""fogbench, the bench: scenario files into typed objects, the runner and its protocols, reports
and figures, Rerun recordings, the suite, the command line and the benchmark.

It drives the simulated rig (``sim``) and scores the compensation library (``fogcomp``); neither
of those imports anything from here.
"""
