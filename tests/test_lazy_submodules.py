"""``import jaxstiff`` loads its public names lazily (jaxstiff.runtime._lazy); its submodules must be
reachable the same way: the README's ``jaxstiff.paths.line(...)`` right after ``import jaxstiff``
raised AttributeError (found by an independent check). Checked in a fresh interpreter, where
nothing else has imported them."""

from __future__ import annotations

import subprocess
import sys

_CODE = """
import sys
import jaxstiff
assert "jaxstiff.paths" not in sys.modules
print(callable(jaxstiff.paths.line), callable(jaxstiff.results.verify), callable(jaxstiff.csc.csc_rollout))
print(jaxstiff.paths is sys.modules["jaxstiff.paths"])
try:
    jaxstiff.no_such_thing
except AttributeError as e:
    print(e)
"""


def test_submodules_are_reachable_after_import_jaxstiff():
    out = subprocess.run([sys.executable, "-c", _CODE], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[0] == "True True True"
    assert out[1] == "True"
    assert out[2] == "module 'jaxstiff' has no attribute 'no_such_thing'"
