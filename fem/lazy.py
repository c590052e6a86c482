"""Packages whose public names are imported on first use (PEP 562), so that a command
line that needs one part (its version, its help) does not import them all."""

from __future__ import annotations

import sys
import types
from importlib import import_module


class _LazyPackage(types.ModuleType):
    """A package module whose public names keep their meaning: the import system sets a
    submodule as an attribute of its package (``identify.predict`` the module, after
    ``import identify.predict``), which would hide the public function of the same name."""

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and name in self._homes:
            return
        super().__setattr__(name, value)


def lazy_package(name: str, homes: dict[str, str]):
    """Make package ``name`` import each public name from its module in ``homes`` (public
    name -> dotted module) when first used; returns its module-level ``__getattr__``."""
    package = sys.modules[name]
    package._homes = homes
    package.__class__ = _LazyPackage

    def __getattr__(attribute: str):
        if attribute not in homes:
            try:
                return import_module(f"{name}.{attribute}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{name}.{attribute}":
                    raise
            raise AttributeError(f"module {name!r} has no attribute {attribute!r}")
        value = getattr(import_module(homes[attribute]), attribute)
        types.ModuleType.__setattr__(package, attribute, value)
        return value

    return __getattr__


__all__ = ["lazy_package"]
