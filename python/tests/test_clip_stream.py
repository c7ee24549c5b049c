"""represent_clip, Stream and motion_score against represent, pair by pair."""

import numpy as np
import pytest

import reynoldsflow as rf
from conftest import clip, moving_frame

OPTIONS = [{}, {"engine": "float"}, {"scale": (8, 32)}, {"variant": "cd", "engine": "float", "scale": "fixed:4,16"}]


@pytest.mark.parametrize("options", OPTIONS)
def test_represent_clip_is_a_loop_of_represent(options):
    c = clip(6)
    reps = rf.represent_clip(c, **options)
    assert reps.shape == (5, 32, 48, 3) and reps.dtype == np.uint8
    for i in range(5):
        assert np.array_equal(reps[i], rf.represent(c[i], c[i + 1], **options)), i
    kept = rf.represent_clip(c, keep_count=True, **options)
    assert kept.shape == (6, 32, 48, 3)
    assert np.array_equal(kept[:5], reps) and np.array_equal(kept[5], reps[4])
    two = rf.represent_clip(c[:2], keep_count=True, **options)
    assert two.shape == (2, 32, 48, 3) and np.array_equal(two[0], two[1])


def test_thread_counts_give_identical_bytes():
    c = clip(9, 64, 40)
    one = rf.represent_clip(c, threads=1)
    two = rf.represent_clip(c, threads=2)
    assert one.tobytes() == two.tobytes()
    assert rf.represent_clip(c, threads=5).tobytes() == one.tobytes()
    assert rf.represent_clip(c).tobytes() == one.tobytes()


def test_stream_equals_represent_pair_by_pair():
    c = clip(5)
    for options in OPTIONS:
        s = rf.Stream(48, 32, **options)
        assert (s.width, s.height) == (48, 32)
        assert s.push(c[0]) is None
        for i in range(1, 5):
            assert np.array_equal(s.push(c[i]), rf.represent(c[i - 1], c[i], **options)), i
        s.reset()
        assert s.push(c[3]) is None
        assert np.array_equal(s.push(c[1][..., None]), rf.represent(c[3], c[1], **options))
    # A refused frame leaves the stream where it was.
    s = rf.Stream(48, 32)
    s.push(c[0])
    with pytest.raises(ValueError):
        s.push(c[1][:, :40])
    assert np.array_equal(s.push(c[1]), rf.represent(c[0], c[1]))


def test_stream_first_frame_policies_give_the_element_s_outputs():
    c = clip(4)
    pairs = [rf.represent(c[i], c[i + 1]) for i in range(3)]
    zeros = np.zeros_like(pairs[0])
    drop, black, repeat = (rf.Stream(48, 32, first_frame=p) for p in ("drop", "black", "repeat"))
    assert (drop.first_frame, black.first_frame, repeat.first_frame) == ("drop", "black", "repeat")
    # push: at most one image per frame.
    assert drop.push(c[0]) is None and np.array_equal(black.push(c[0]), zeros)
    for i in range(1, 4):
        assert np.array_equal(drop.push(c[i]), pairs[i - 1]) and np.array_equal(black.push(c[i]), pairs[i - 1])
    # feed: every image, one per frame with repeat (the first a copy of the first pair's).
    got = [repeat.feed(f) for f in c] + [repeat.end()]
    assert [len(g) for g in got] == [0, 2, 1, 1, 0]
    expected = [pairs[0], pairs[0], pairs[1], pairs[2]]
    assert all(np.array_equal(a, b) for a, b in zip(sum(got, []), expected))
    assert got[1][0] is not got[1][1]
    # A stream of one frame still gives its frame an image: itself, paired with itself.
    assert repeat.feed(c[2]) == [] and len(lone := repeat.end()) == 1
    assert np.array_equal(lone[0], rf.represent(c[2], c[2]))
    # end() and reset() make the next frame a first frame.
    black.end()
    assert np.array_equal(black.feed(c[1])[0], zeros)
    drop.reset()
    assert drop.feed(c[1]) == [] and np.array_equal(drop.feed(c[2])[0], pairs[1])
    with pytest.raises(ValueError, match="feed"):
        repeat.push(c[0])
    with pytest.raises(ValueError, match="first_frame"):
        rf.Stream(48, 32, first_frame="twice")


@pytest.mark.parametrize("size", [(48, 32), (641, 7), (5, 300)])
def test_stream_threads_give_the_bytes_of_one(size):
    w, h = size
    c = clip(3, w, h)
    for threads in (2, 3, None):
        one = [rf.Stream(w, h, threads=1, layout=layout) for layout in ("hwc", "chw")]
        many = [rf.Stream(w, h, threads=threads, layout=layout) for layout in ("hwc", "chw")]
        for f in c:
            for a, b in zip(one, many):
                x, y = a.feed(f), b.feed(f)
                assert len(x) == len(y) and all(np.array_equal(p, q) for p, q in zip(x, y)), threads
    with pytest.raises(ValueError, match="threads"):
        rf.Stream(w, h, threads=0)


def test_motion_scores():
    c = clip(5)
    reps, scores = rf.represent_clip(c, return_scores=True)
    assert np.array_equal(reps, rf.represent_clip(c))
    assert scores.shape == (4,) and scores.dtype == np.float64
    for i in range(4):
        assert scores[i] == rf.motion_score(c[i], c[i + 1])
        fields = rf.fields(c[i], c[i + 1])
        mean = np.hypot(fields["v_R"][..., 0].astype(np.float64), fields["v_R"][..., 1]).mean()
        assert scores[i] == pytest.approx(mean, rel=1e-5)
    # Static pairs score 0; a moving pair scores more; more motion, more score.
    still = moving_frame(48, 32, 0)
    assert rf.motion_score(still, still) == 0.0
    assert rf.motion_score(still, moving_frame(48, 32, 1)) > 0.05
    assert rf.motion_score(still, moving_frame(48, 32, 2)) > rf.motion_score(still, moving_frame(48, 32, 1))
    _, kept_scores = rf.represent_clip(c, keep_count=True, return_scores=True)
    assert np.array_equal(kept_scores, scores)
