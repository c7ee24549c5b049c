"""Convert a dataset with Ray: `reynoldsflow.convert` mapped over the items
of `reynoldsflow dataset SRC DST`, one task per video or frame folder.

The outputs are byte for byte those of `reynoldsflow dataset SRC DST` (same
files, same completion markers), so the two can finish each other's work:
finished items are skipped on a rerun, by either.

    python ray_dataset.py SRC DST --num-cpus 8            # a local Ray
    python ray_dataset.py SRC DST --address auto          # a running cluster
    python ray_dataset.py SRC DST --status status.jsonl --keep-count

Every worker needs the `reynoldsflow-rs` wheel installed (pip install
reynoldsflow_rs-*.whl; ffmpeg too for videos other than .y4m). Prints a summary; the exit status is 1 if any item failed.
"""

import argparse
import json
import os
import sys

import ray

import reynoldsflow


@ray.remote(num_cpus=1)
def convert(src: str, out: str, options: dict) -> dict:
    # One core per task: Ray runs as many tasks as the cluster has CPUs.
    return reynoldsflow.convert(src, out, threads=1, **options)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("src")
    p.add_argument("dst")
    p.add_argument("--address", help="a running Ray cluster (e.g. auto); default: start a local one")
    p.add_argument("--num-cpus", type=int, help="CPUs of the local Ray (default: all)")
    p.add_argument("--files-from", help="only the items listed (one path relative to SRC per line)")
    p.add_argument("--status", help="append the JSON-lines status records here (default: stdout)")
    p.add_argument("--keep-count", action="store_true", help="one output per frame (the last repeated)")
    p.add_argument("--engine", default="fixed", choices=["fixed", "float"])
    p.add_argument("--scale", default="minmax", help="minmax or fixed:KD,KC")
    p.add_argument("--variant", default="dc", choices=["dc", "dc0", "cd", "hsv"])
    p.add_argument("--force", action="store_true", help="redo finished items")
    args = p.parse_args(argv)

    options = {
        "keep_count": args.keep_count,
        "engine": args.engine,
        "scale": args.scale,
        "variant": args.variant,
        "force": args.force,
    }
    items = reynoldsflow.dataset_items(args.src, files_from=args.files_from, dst=args.dst)
    if not items:
        print(f"{args.src}: no videos or frame folders found", file=sys.stderr)
        return 1
    if args.address:
        ray.init(address=args.address)
    else:
        ray.init(num_cpus=args.num_cpus, include_dashboard=False)
    try:
        pending = [convert.remote(src, os.path.join(args.dst, rel), options) for src, rel in items]
        log = open(args.status, "a") if args.status else sys.stdout
        records = []
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for record in ray.get(done):
                records.append(record)
                log.write(json.dumps(record) + "\n")
                log.flush()
        if log is not sys.stdout:
            log.close()
    finally:
        ray.shutdown()
    failed = [r for r in records if r["status"] == "failed"]
    counts = {s: sum(r["status"] == s for r in records) for s in ("done", "skipped", "failed")}
    print(f"ray_dataset: {len(records)} items: {counts['done']} done, {counts['skipped']} skipped, "
          f"{counts['failed']} failed", file=sys.stderr)
    for r in failed:
        print(f"ray_dataset: failed: {r['error']}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
