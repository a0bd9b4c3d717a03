"""One fdv.Perception used from several Python threads: its calls are serialised and each push is
whole or refused, so the counts equal what the threads had accepted (the adversarial scripts
race_finish_segv.py and race_two_pushers.py). The ThreadSanitizer build runs this file with the
sanitizer's runtime preloaded (python/CMakeLists.txt): a data race in the binding or the pipeline
below it is a report there, and ends the run."""
import threading

import numpy as np
import pytest

import fdv


@pytest.fixture(scope="module")
def throw(tmp_path_factory):
    """A short simulated throw, small enough for the sanitizer build: its calibration and events."""
    out = tmp_path_factory.mktemp("threads") / "throw"
    fdv.simulate("scene2_ball", seed=3, out=str(out), duration=0.3, resolution=(160, 120))
    recording = fdv.open(str(out))
    return recording.calibration, np.concatenate(list(recording.events()), dtype=fdv.EVENT_DTYPE)


def push_slices(perception, events, size, accepted, refused):
    """Pushes events[i:i + size] for each i; counts the events of accepted pushes, keeps refusals."""
    for i in range(0, len(events), size):
        try:
            perception.push_events(events[i:i + size])
            accepted.append(len(events[i:i + size]))
        except ValueError as e:
            refused.append(str(e))


def test_finish_racing_pushes_counts_exactly_the_pushes_before_it(throw):
    calibration, events = throw
    assert len(events) > 20000
    for attempt in range(3):
        p = fdv.Perception(calibration)
        accepted, refused = [], []
        pusher = threading.Thread(target=push_slices, args=(p, events, 2000, accepted, refused))
        pusher.start()
        result = p.finish()
        pusher.join()
        assert all("used after finish()" in r for r in refused), refused
        # Every push before finish() is counted, none after it.
        assert result["counts"]["events_read"] == sum(accepted), attempt


def test_two_threads_pushing_one_stream_each_push_is_whole_or_refused(throw):
    calibration, events = throw
    p = fdv.Perception(calibration)
    accepted, refused = [[], []], [[], []]
    threads = [threading.Thread(target=push_slices, args=(p, events, 2000, accepted[k], refused[k]))
               for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    result = p.finish()
    for reasons in refused:
        assert all("go backwards" in r and "nothing of this array was pushed" in r for r in reasons), reasons
    assert result["counts"]["events_read"] == sum(accepted[0]) + sum(accepted[1])
    # Each slice of the stream went in once at least (a thread's push that follows the other's
    # copy of the same slice goes backwards, unless all its events share one time).
    assert sum(accepted[0]) + sum(accepted[1]) >= len(events)
