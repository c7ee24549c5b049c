"""Benchmarks that drive the package (``python -m reynoldsflow.bench.downstream``)."""
