"""The affordances: each one declared once, in its own module, and registered here.

- :mod:`.registry`: :class:`Affordance`, :class:`ExampleSpec`, :class:`JudgeRule`, the registry
  (:func:`register`, :func:`get`, :func:`names`, :func:`spec`) and the examples
  (:func:`build`, :func:`build_descriptor`)
- :mod:`.placing`, :mod:`.sitting`, :mod:`.hanging`, :mod:`.filling`, :mod:`.riding`: the
  paper's five affordances

Adding one is a module of the same shape plus a line below (or :func:`register` from your own
code): see ``docs/architecture.md``.
"""

from interaction_tensor.affordances import filling, hanging, placing, riding, sitting
from interaction_tensor.affordances.registry import (
    DOWN,
    UP,
    Affordance,
    Example,
    ExampleSpec,
    JudgeRule,
    Posed,
    acceptance,
    acceptances,
    build,
    build_descriptor,
    example_names,
    get,
    names,
    of,
    register,
    spec,
    train_settings,
    unregister,
)

for _module in (filling, placing, hanging, sitting, riding):
    register(_module.AFFORDANCE)

__all__ = ["DOWN", "UP", "Affordance", "Example", "ExampleSpec", "JudgeRule", "Posed",
           "acceptance", "acceptances", "build", "build_descriptor", "example_names", "get", "names", "of",
           "register", "spec", "train_settings", "unregister"]
