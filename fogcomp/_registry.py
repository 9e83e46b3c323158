"""The registry: which names find which method classes.

The built-in methods (``fogcomp.methods``, registered by :func:`register` as they are imported),
plug-ins declared as entry points of the group ``fogcomp.methods`` (``importlib.metadata``, as
pytest finds its plug-ins), and any class named ``module:Class`` of an importable, installed
module (never a file path). :func:`get_method` finds a class, :func:`make_method` an instance,
:func:`method_id` the name that finds a class again (what a saved model records).
"""

from __future__ import annotations

import warnings

import re

__all__ = [
    "ENTRY_POINT_GROUP",
    "PluginError",
    "available_methods",
    "class_problem",
    "get_method",
    "make_method",
    "method_id",
    "plugin_problems",
    "register",
]

ENTRY_POINT_GROUP = "fogcomp.methods"

_REGISTRY: dict[str, type] = {}
_PLUGIN_PROBLEMS: dict[str, str] = {}     # entry-point name -> why it could not be loaded
_SHADOW_SAID: set[str] = set()            # built-in names whose shadowing plug-in was named


class PluginShadowWarning(UserWarning):
    """An installed entry point has the name of a built-in method: the built-in runs."""
_ENTRY_POINTS_READ = False
_CLASS_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*:"
                         r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


class PluginError(KeyError):
    """A plug-in method that cannot be used: its module does not import, or what it names is
    not a usable :class:`~fogcomp.Compensator` subclass. The message gives the reason. (A
    KeyError, as an unknown name is, so that callers refusing unknown methods refuse these too;
    the runner tells them apart and reports the method as failed instead.)"""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def register(cls: type) -> type:
    """Class decorator: make a method (a :class:`~fogcomp.Compensator` subclass) findable by
    its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__} has no registry name")
    if cls.name in _REGISTRY and _REGISTRY[cls.name] is not cls:
        raise ValueError(f"method name {cls.name!r} is registered twice")
    _REGISTRY[cls.name] = cls
    return cls


def class_problem(cls) -> str | None:
    """Why ``cls`` cannot be a method (None: it can): the structural contract checked before
    any data (the behaviour is :func:`fogcomp.check_method`'s).

    A method is a subclass of :class:`fogcomp.Compensator`, whose ``_contract_problem`` checks
    the rest (its name, ``requires``, the methods it implements, its hyperparameters). This
    module sits below the estimator's (``Compensator.save`` writes model files, and loading
    them looks the method up here), so it asks the class rather than import Compensator."""
    check = getattr(cls, "_contract_problem", None) if isinstance(cls, type) else None
    if check is None:
        return f"{cls!r} is not a subclass of fogcomp.Compensator"
    return check()


def _read_entry_points() -> None:
    """Load the plug-ins of the ``fogcomp.methods`` entry-point group once; one that fails to
    import or is no usable method is kept in ``_PLUGIN_PROBLEMS`` with the reason."""
    global _ENTRY_POINTS_READ
    if _ENTRY_POINTS_READ:
        return
    _ENTRY_POINTS_READ = True
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in _REGISTRY:
            if getattr(_REGISTRY[ep.name], "__module__", "").startswith("fogcomp."):
                _PLUGIN_PROBLEMS[ep.name] = (f"entry point {ep.name!r} ({ep.value}) has the "
                                             "name of a built-in method")
            continue
        try:
            cls = ep.load()
        except BaseException as exc:  # noqa: BLE001 (a plug-in's import may do anything)
            if isinstance(exc, KeyboardInterrupt):
                raise
            _PLUGIN_PROBLEMS[ep.name] = (f"entry point {ep.name!r} ({ep.value}) does not "
                                         f"import: {type(exc).__name__}: {exc}")
            continue
        problem = class_problem(cls)
        if problem is None and cls.name != ep.name:
            problem = (f"entry point {ep.name!r} ({ep.value}) names a class whose 'name' is "
                       f"{cls.name!r}; they must agree")
        if problem:
            _PLUGIN_PROBLEMS[ep.name] = f"entry point {ep.name!r}: {problem}"
        else:
            _REGISTRY[ep.name] = cls


def available_methods() -> list[str]:
    """Method names, sorted: the built-ins and the plug-ins of the entry-point group
    ``fogcomp.methods`` that load (:func:`plugin_problems` lists those that do not)."""
    from . import methods  # noqa: F401  (registers the built-in methods)

    _read_entry_points()
    return sorted(_REGISTRY)


def plugin_problems() -> dict[str, str]:
    """Entry-point plug-ins that could not be loaded: name -> reason."""
    available_methods()
    return dict(_PLUGIN_PROBLEMS)


def _import_class(name: str) -> type:
    import importlib

    if not _CLASS_NAME.match(name):
        raise KeyError(f"method {name!r}: a plug-in class is named module:Class (an importable, "
                       "installed module, e.g. mypkg.methods:MyMethod), never a file path")
    mod_name, _, qual = name.partition(":")
    try:
        obj = importlib.import_module(mod_name)
    except ModuleNotFoundError as exc:
        if exc.name and (mod_name == exc.name or mod_name.startswith(exc.name + ".")):
            raise KeyError(f"method {name!r}: no module {exc.name!r} is installed (pip install "
                           "the plug-in's package into this environment)") from None
        raise PluginError(f"method {name!r}: its module does not import: "
                          f"ModuleNotFoundError: {exc}") from None
    except BaseException as exc:  # noqa: BLE001 (a plug-in's import may do anything)
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise PluginError(f"method {name!r}: its module does not import: "
                          f"{type(exc).__name__}: {exc}") from None
    for part in qual.split("."):
        if not hasattr(obj, part):
            raise KeyError(f"method {name!r}: module {mod_name!r} has no {qual!r}")
        obj = getattr(obj, part)
    problem = class_problem(obj)
    if problem:
        raise PluginError(f"method {name!r}: {problem}")
    return obj


def get_method(name: str) -> type:
    """The class registered under ``name`` (a built-in or an entry-point plug-in), or the class
    ``module:Class`` names.

    Returns
    -------
    type
        The method's :class:`~fogcomp.Compensator` subclass.

    Raises
    ------
    KeyError
        An unknown name (the message lists the available ones).
    PluginError
        A plug-in that does not import or is not a usable method (the message says why).
    """
    names = available_methods()
    if name in _REGISTRY:
        if name in _PLUGIN_PROBLEMS and name not in _SHADOW_SAID:   # an entry point took the name
            _SHADOW_SAID.add(name)
            warnings.warn(f"{_PLUGIN_PROBLEMS[name]}: the built-in {name!r} runs; name the "
                          "plug-in by its module:Class to run it instead", PluginShadowWarning,
                          stacklevel=2)
        return _REGISTRY[name]
    if name in _PLUGIN_PROBLEMS:
        raise PluginError(_PLUGIN_PROBLEMS[name])
    if ":" in name:
        return _import_class(name)
    raise KeyError(f"unknown method {name!r}; available: {', '.join(names)} (or a plug-in "
                   "named module:Class; a plug-in package is found once it is installed in "
                   "this environment, e.g. .venv/bin/pip install PATH, under the entry point "
                   "group fogcomp.methods)")


def method_id(cls: type) -> str:
    """The name that finds ``cls`` again (:func:`get_method`): its registry name when it is
    registered under it, else ``module:Class``."""
    if _REGISTRY.get(cls.name) is cls:
        return cls.name
    return f"{cls.__module__}:{cls.__qualname__}"


def make_method(name: str, **hyperparameters):
    """An instance of method ``name`` with ``hyperparameters`` overriding the paper's defaults.

    The hyperparameters are checked at once (:meth:`~fogcomp.Compensator.check_params`), so a
    wrong type or value is a ``ValueError`` naming the hyperparameter here, not after minutes of
    work in ``fit``.

    Returns
    -------
    Compensator
        The method, not fitted.
    """
    import inspect

    cls = get_method(name)
    allowed = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    unknown = sorted(set(hyperparameters) - set(allowed))
    if unknown:
        raise ValueError(f"method {name!r}: unknown hyperparameter(s) {unknown}; "
                         f"allowed: {allowed}")
    model = cls(**hyperparameters)
    model.check_params()
    return model
