"""The launcher notes every stop signal (``Launch._interrupted``), so a Ctrl-C, SIGTERM or SIGHUP that
surfaces inside a callback as another error still stops the run cleanly."""

import signal

import pytest

from track_nodes.launch.launcher import Launch


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM, signal.SIGHUP], ids=['SIGINT', 'SIGTERM', 'SIGHUP'])
def test_a_stop_signal_is_noted_whatever_its_number(sig):
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    launch = object.__new__(Launch)  # only the signal watch: no scenario, no nodes
    launch._watch_sigint()
    try:
        assert not launch._interrupted()
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(sig)
        assert launch._interrupted() and launch._interrupted()  # noted once, remembered
    finally:
        signal.set_wakeup_fd(-1)
        for s, h in handlers.items():
            signal.signal(s, h)
        launch._sig_r.close()
        launch._sig_w.close()
