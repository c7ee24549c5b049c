"""Does ReynoldsFlow help a detector? The paper's comparison, on tiny drones.

    python -m reynoldsflow.bench.downstream --out DIR [--quick] [--seeds N]

Two detectors -- a small fully convolutional heatmap network and the
paper's YOLO11n (ultralytics, from scratch, offline) -- are trained with the
same budget, data and seeds on each input computed from the same frame
pairs: the gray frame, frame differences, the HSV-coded flow of five
classical OpenCV methods, the ReynoldsFlow representation computed by this
package and its ablations. Two scene families: generated 160x120 skies with
switchable nuisance factors, and real videos with a composited drone
(split by source video between training and test). Each input's AP, AP50
and AP50-95 get bootstrap 95 % intervals, and each baseline a paired
difference against the representation. Writes report.md, results.csv,
intervals.csv and plot.png into DIR.

Modules, one concept each: ``scenes`` (the generated clips and their ground
truth), ``backgrounds`` (real footage with a composited drone), ``flow``
(classical optical flow coded as images), ``inputs`` (what the detectors
see), ``detector`` (the heatmap network, its training and inference),
``yolo`` (YOLO11n's training and inference), ``metrics`` (located within
3 px, AP, AP50, AP50-95), ``stats`` (bootstrap intervals and paired
differences), ``report`` (CSV, markdown, plot, atomic writes) and ``run``
(the command: options, jobs in worker processes, the report).
"""
