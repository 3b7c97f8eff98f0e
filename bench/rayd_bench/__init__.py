"""rayd's benchmark driver (python3 -m rayd_bench; see bench/README.md)."""
