"""Does the input make a tiny drone stand out? A training-free study.

    python -m reynoldsflow.bench.separability --out DIR [--quick] [--backgrounds DIR]

On the downstream benchmark's composites (generated skies; real footage
with a composited drone, training and test clips from different videos),
for every input the benchmark has and every channel of it: the drone's
signal-to-clutter ratio (SCR), its gain over the gray frame, the
background suppression factor, and the probability of detection at false-
alarm rates of 1e-3, 1e-4 and 1e-5 per pixel of a threshold on each channel
and on a linear combination of an input's channels fitted on training clips
only; across drone size, contrast and speed; bootstrap 95 % intervals over
clips and seeds and paired differences rf - each input. Writes report.md,
intervals.csv and plot.png into DIR.

Modules: ``measure`` (the statistics and their windows, the bootstrap),
``channels`` (every input's channels as maps), ``job`` (one seed of one
family), ``report`` (the intervals and the outputs) and ``run`` (the command).
"""
