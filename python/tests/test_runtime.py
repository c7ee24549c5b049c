"""The GIL is released while computing, and repeated calls do not leak."""

import threading
import time

import numpy as np

import reynoldsflow as rf
from conftest import clip, moving_frame


def count_during(action):
    """Iterations a Python thread's loop makes while `action` runs, and the seconds."""
    count = 0
    stop = threading.Event()
    started = threading.Event()

    def counter():
        nonlocal count
        started.set()
        while not stop.is_set():
            count += 1

    t = threading.Thread(target=counter)
    t.start()
    started.wait()
    begin_count, begin = count, time.perf_counter()
    action()
    end_count, seconds = count, time.perf_counter() - begin
    stop.set()
    t.join()
    return end_count - begin_count, seconds


def test_a_python_thread_keeps_counting_while_a_large_pair_computes():
    big0, big1 = moving_frame(1920, 1440, 0), moving_frame(1920, 1440, 1)
    rf.represent(big0[:64, :64], big1[:64, :64])
    def calls_for(seconds):
        # As many calls as fill `seconds`, however fast the machine: holding
        # the GIL, they would keep the counter near 0 (a switch interval
        # between calls at most); released, it runs at about its free rate.
        def action():
            end = time.perf_counter() + seconds
            while time.perf_counter() < end:
                rf.represent(big0, big1)

        return action

    rates = []
    for _ in range(2):
        free, free_s = count_during(lambda: time.sleep(0.4))
        busy, busy_s = count_during(calls_for(0.4))
        rates.append((free / free_s, busy / busy_s, busy_s))
    print("free-running vs during the call (iterations/s, call seconds):", rates)
    for free_rate, busy_rate, _ in rates:
        assert busy_rate > 0.25 * free_rate, rates
    # The clip's workers too.
    c = np.stack([moving_frame(960, 720, t) for t in range(5)])
    free, free_s = count_during(lambda: time.sleep(0.3))
    busy, busy_s = count_during(lambda: rf.represent_clip(c, threads=1))
    assert busy / busy_s > 0.25 * free / free_s, (free / free_s, busy / busy_s)


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


def test_a_thousand_calls_leave_resident_memory_flat():
    f0, f1 = moving_frame(96, 64, 0), moving_frame(96, 64, 1)
    c = clip(4, 96, 64)
    s = rf.Stream(96, 64)

    def calls(n):
        for i in range(n):
            rf.represent(f0, f1)
            rf.fields(f0, f1)
            rf.motion_score(f0, f1)
            s.push(f0 if i % 2 else f1)
            if i % 10 == 0:
                rf.represent_clip(c, threads=2, return_scores=True)
            try:
                rf.represent(f0, f1[:, :5])
            except ValueError:
                pass

    calls(100)
    before = rss_bytes()
    calls(1000)
    grown = rss_bytes() - before
    print(f"resident memory after 1000 more calls: {grown / 2**20:+.2f} MiB")
    # One leaked output per call would be over 18 MiB for represent alone.
    assert grown < 4 * 2**20, grown
