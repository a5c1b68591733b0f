"""Stop signals are idempotent (``Launch._on_stop_signal``): the first one stops the run, a second one while it
is taken, or any once the run is torn down, is noted and raises nothing (it gave a traceback and exit -2)."""

import signal

import pytest

from track_nodes.launch.launcher import Launch


@pytest.fixture
def launch():
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    launch = object.__new__(Launch)  # only the signal watch: no scenario, no nodes
    launch.dog = None
    launch._watch_sigint()
    try:
        yield launch
    finally:
        signal.set_wakeup_fd(-1)
        for s, h in handlers.items():
            signal.signal(s, h)
        launch._sig_r.close()
        launch._sig_w.close()


def test_a_second_stop_signal_raises_nothing(launch):
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGTERM)
    signal.raise_signal(signal.SIGTERM)  # 0.2 s later in a real run: while the first is being taken
    signal.raise_signal(signal.SIGINT)
    assert launch._interrupted()


def test_a_stop_signal_during_teardown_raises_nothing(launch):
    launch._stopping = True  # set where the run's teardown begins (Launch._run)
    signal.raise_signal(signal.SIGHUP)
    assert launch._interrupted()  # noted: the drain and the grace are cut short


def test_the_watchdog_cuts_once_even_after_a_stop(launch):
    class Stalled:
        stalled = 'the timer of stuck has not returned'

    launch._deferring = True  # the clock runs: a user's stop is deferred to the next turn
    signal.raise_signal(signal.SIGINT)
    launch.dog = Stalled()
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGINT)  # the watchdog's own SIGINT cuts the callback that hangs
    signal.raise_signal(signal.SIGINT)
