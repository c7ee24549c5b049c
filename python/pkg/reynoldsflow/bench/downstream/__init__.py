"""Does ReynoldsFlow help a detector? A downstream tiny-drone benchmark.

    python -m reynoldsflow.bench.downstream --out DIR [--quick] [--seeds N]

One small fully convolutional heatmap detector (PyTorch, CPU) is trained with
the same budget, data, crops and seeds on each input -- the gray frame, frame
differences, the ReynoldsFlow representation computed by this package and its
variants -- on generated 160x120 tiny-drone clips with separately switchable
nuisance factors, then scored on held-out clips per factor. Writes report.md,
results.csv and plot.png into DIR.

Modules, one concept each: ``scenes`` (the generated clips and their ground
truth), ``inputs`` (what the detector sees), ``detector`` (the network, its
training and inference), ``metrics`` (located within 3 px, AP, false
positives per drone-free frame at a fixed recall), ``report`` (CSV, markdown,
plot, atomic writes) and ``run`` (the command: options, jobs in
worker processes, the report).
"""
