"""A detector benchmark sized to resolve: does a small learned detector
find a tiny drone better on the representation than on gray, frame
difference or a classical flow?

    python -m reynoldsflow.bench.detection --out DIR [--quick] [--calibrate]

Per scene family and seed, thousands of distinct composited 64x64 patches
(new background crop, drone path, size and contrast for each; generated
skies or real footage, training and test from different videos), every
input computed on each; the downstream benchmark's heatmap network trained
on each input with the same crops in the same order until its validation
AP stops rising (the curve is reported), then AP (3 px) on held-out
patches; bootstrap 95 % intervals over seeds and patches, paired
differences rf - each input. The task's difficulty (the drone's size and
contrast ranges) is calibrated once, on the gray input only, with seeds
apart from the evaluation's (``--calibrate``), and fixed in CALIBRATED.

Modules: ``patches`` (the composited patches and their inputs), ``train``
(early-stopped training, detection), ``run`` (the command, the statistics,
the report).
"""
