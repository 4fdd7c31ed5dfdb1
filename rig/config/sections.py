"""Optional top-level sections of a rig file, validated by whoever owns them.

The simulated rig owns ``sim:`` and ``faults:``; their schemas live in
``rig/simulation/settings.py`` and register themselves here (importing ``rig.simulation`` does
it). ``rig.config`` imports no simulator: when a rig file has such a section and its schema is
not registered yet, :func:`section` imports the provider named in :data:`PROVIDERS` by its
module-name string, so loading a rig file gives the same answer whatever was imported before,
and a hardware-only installation still loads hardware rig files.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

#: section name -> module that registers its schema when imported
PROVIDERS: dict[str, str] = {"sim": "rig.simulation", "faults": "rig.simulation"}


@dataclass(frozen=True)
class Section:
    """A registered section: its pydantic model and the rig kinds it belongs to (None: any)."""

    name: str
    model: type
    kinds: tuple[str, ...] | None = None
    doc: str = ""


_REGISTRY: dict[str, Section] = {}


def register_section(name: str, model: type, *, kinds: tuple[str, ...] | None = None, doc: str = "") -> None:
    """Validate the rig file's top-level ``name:`` section with ``model`` from now on."""
    _REGISTRY[name] = Section(name, model, kinds, doc)


def section_names() -> list[str]:
    """Every section a rig file may have beyond the core keys (registered or with a provider)."""
    return sorted(set(PROVIDERS) | set(_REGISTRY))


class SectionUnavailable(LookupError):
    """The provider of a section cannot be imported (e.g. an installation without the simulator)."""


def section(name: str) -> Section:
    """The registered schema of section ``name``, importing its provider on first use."""
    if name not in _REGISTRY and name in PROVIDERS:
        try:
            importlib.import_module(PROVIDERS[name])
        except ImportError as exc:
            raise SectionUnavailable(f"needs {PROVIDERS[name]}, which cannot be imported here ({exc})") from None
    if name not in _REGISTRY:
        raise SectionUnavailable(f"no schema is registered for the {name!r} section")
    return _REGISTRY[name]
