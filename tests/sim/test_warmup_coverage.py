"""The warm-up (``python -m hil.sim.warmup``, run by ``make``) reaches every numba-compiled
function in the package (issue 33 item 2): a fresh interpreter runs it, then every module of
``hil`` is imported and each numba dispatcher defined there is listed; a dispatcher counts as
warmed if the warm-up compiled or loaded it, or a warmed one calls it (its machine code is then
inside the caller's). A new kernel no warm-up path reaches fails this test by name."""

import json
import subprocess
import sys

PROBE = r"""
import importlib, json, pathlib, pkgutil, re, types
from numba.core.dispatcher import Dispatcher
import hil
from hil.warmup import warm_up

warm_up()
kernels = {}
for info in pkgutil.walk_packages(hil.__path__, "hil."):
    if info.name.endswith("__main__") or ".migrations" in info.name:  # scripts, not modules
        continue
    try:
        module = importlib.import_module(info.name)
    except ModuleNotFoundError as exc:   # the motulator plant's modules run in .venv-motulator
        if exc.name != "motulator":      # (they hold no numba kernel); anything else fails
            raise
        continue
    for name, obj in vars(module).items():
        if isinstance(obj, Dispatcher) and obj.py_func.__module__ == module.__name__:
            kernels[f"{module.__name__}.{obj.py_func.__qualname__}"] = obj


def callees(dispatcher):
    code, names = dispatcher.py_func.__code__, set(dispatcher.py_func.__code__.co_names)
    for const in code.co_consts:                      # nested functions and comprehensions
        if isinstance(const, types.CodeType):
            names |= set(const.co_names)
    found = []
    for name in names:
        value = dispatcher.py_func.__globals__.get(name)
        if isinstance(value, Dispatcher):
            found.append(value)
        elif isinstance(value, types.ModuleType):     # module.kernel(...)
            found += [getattr(value, attr) for attr in names
                      if isinstance(getattr(value, attr, None), Dispatcher)]
    return found


sources = "\n".join(p.read_text() for p in pathlib.Path(hil.__path__[0]).rglob("*.py"))
# a kernel no package code calls (only a test does) is no part of a run
uncalled = sorted(k for k in kernels if len(re.findall(rf"\b{re.escape(k.rsplit('.', 1)[1])}\(",
                                                       sources)) < 2)   # the def itself
warmed = [d for d in kernels.values() if d.signatures]
reached, stack = set(), list(warmed)
while stack:
    d = stack.pop()
    if id(d) not in reached:
        reached.add(id(d))
        stack += callees(d)
print(json.dumps({"kernels": sorted(kernels),
                  "entry_points": sorted(k for k, d in kernels.items() if d.signatures),
                  "uncalled": uncalled,
                  "not_reached": sorted(k for k, d in kernels.items()
                                        if id(d) not in reached and k not in uncalled)}))
"""


def test_warm_up_reaches_every_numba_kernel():
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    # the enumeration is real: it finds the kernels of all three packages
    for package in ("hil.sim.", "hil.analysis.", "hil.model."):
        assert any(k.startswith(package) for k in found["entry_points"]), package
    assert len(found["kernels"]) >= 40
    assert len(found["uncalled"]) <= 2, found["uncalled"]   # test-only references, few
    assert found["not_reached"] == [], found["not_reached"]
