"""Benchmarks that drive the package: ``python -m reynoldsflow.bench.downstream``
(the detector benchmark) and ``python -m reynoldsflow.bench.footage`` (a
qualitative panel on real footage)."""
