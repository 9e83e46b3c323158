"""Truth closure: ``python -m fogbench.bench.truth_closure`` (see its docstring)."""

from fogbench.bench.truth_closure import main

if __name__ == "__main__":
    main()
