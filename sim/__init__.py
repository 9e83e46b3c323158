"""The simulated rig: MuJoCo rate table, motion programs, thermal chamber, FOG error model,
Earth rate and device presets. Truth and FOG output only: it knows nothing of scenario files,
methods, reports or the command line (those are the bench, ``fogbench``)."""
