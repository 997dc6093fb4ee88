"""Every public function, method and property of the framework (and of the walker library's
modules listed below) has full type hints and a docstring, as ``help()`` shows them: a method
that overrides a documented one inherits its docstring (``inspect.getdoc``)."""
from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

#: walker_library modules checked; the others (cli, analyses.gait, analyses.poincare,
#: analyses.robustness, report.studies) are being reworked and join this list when they are
WALKER_MODULES = ("analyses.cases", "analyses.calibration", "core.walker", "analyses.dissipation",
                  "core.hybrid", "core.machine", "analyses.metrics", "core.plan", "core.problems",
                  "core.protocol", "core.reading",
                  "report.writer", "core.resets", "analyses.results", "analyses.series",
                  "analyses.standing", "core.strides", "core.files", "core.fmu",
                  "core.gradients", "analyses.gradients", "analyses.optimize")


def _modules(package: str):
    root = importlib.import_module(package)
    yield root
    for info in pkgutil.walk_packages(root.__path__, f"{package}."):
        if info.name.endswith(("rodas_loop", "rosenbrock_loop", "bdf_loop", "common_loop",
                               "mechanics.kernel")):   # source templates
            continue
        yield importlib.import_module(info.name)


def _callables(module):
    """(qualified name, function, object whose docstring counts, is a method)."""
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj, obj, False
        elif inspect.isclass(obj):
            for attr, raw in vars(obj).items():
                if attr.startswith("_"):
                    continue
                fn = raw.fget if isinstance(raw, property) else getattr(raw, "__func__", raw)
                if not inspect.isfunction(fn) or not fn.__qualname__.startswith(f"{name}."):
                    continue
                doc = raw if isinstance(raw, property) else getattr(obj, attr)
                yield f"{name}.{attr}", fn, doc, not isinstance(raw, staticmethod)


def _hinted(fn, method: bool) -> bool:
    params = list(inspect.signature(fn).parameters.values())
    if method and params and params[0].name in ("self", "cls"):
        params = params[1:]
    return (all(p.annotation is not inspect.Parameter.empty for p in params)
            and inspect.signature(fn).return_annotation is not inspect.Signature.empty)


def _missing(modules) -> list[str]:
    out = []
    for module in modules:
        for name, fn, doc, method in _callables(module):
            what = [w for w, ok in (("hints", _hinted(fn, method)),
                                    ("docstring", bool(inspect.getdoc(doc)))) if not ok]
            if what:
                out.append(f"{module.__name__}.{name}: no {' or '.join(what)}")
    return out


def test_the_framework_api_has_hints_and_docstrings():
    modules = list(_modules("porthamiltonian"))
    assert len(modules) > 40
    assert _missing(modules) == []


@pytest.mark.parametrize("name", WALKER_MODULES)
def test_walker_modules_have_hints_and_docstrings(name):
    assert _missing([importlib.import_module(f"walker_library.{name}")]) == []
