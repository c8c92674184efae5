"""hold_interrupts: after a run was stopped, further SIGINTs are only remembered until the
command's handlers end; the next command's handlers raise again."""

import os
import signal
import threading

import pytest

from jaxstiff.runtime._io import hold_interrupts, interrupt_handlers, interrupt_pending


def _deliver():
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(1000):  # the handler runs at the next bytecode boundary of the main thread
        interrupt_pending()


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signal handlers: main thread")
def test_held_interrupts_are_remembered_and_the_hold_ends_with_the_handlers(capsys):
    with interrupt_handlers():
        hold_interrupts()
        _deliver()  # would raise KeyboardInterrupt without the hold
        _deliver()
        assert interrupt_pending() == signal.SIGINT
    err = capsys.readouterr().err
    assert err.count("saving what was finished first") == 1  # told once
    with pytest.raises(KeyboardInterrupt), interrupt_handlers():
        _deliver()


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signal handlers: main thread")
def test_a_hold_made_outside_a_command_does_not_hold_the_next_command():
    """A library run stopped by Ctrl-C (a notebook) holds; a command run later in the same process
    must still stop on its first Ctrl-C."""
    before = signal.getsignal(signal.SIGINT)
    hold_interrupts()
    assert signal.getsignal(signal.SIGINT) is before  # the process's own handler untouched
    with pytest.raises(KeyboardInterrupt), interrupt_handlers():
        _deliver()
