"""The runner of ``jaxstiff reproduce`` (:mod:`.runner`) and its report (:mod:`.report`): part of the
source checkout, not of the installed package, like the experiments they run. The command finds
them here (:func:`jaxstiff.cli._reproduce.load_runner`)."""
