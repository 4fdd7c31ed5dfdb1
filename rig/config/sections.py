"""Optional top-level sections of a rig file, validated by whoever owns them.

The rig file names two sections it does not validate itself, ``sim:`` and ``faults:``
(:data:`SECTION_NAMES`); the simulated rig owns both, and their schemas live in
``rig/simulation/settings.py``, which registers them here when it is imported. ``rig.config`` imports
no simulator, by name or otherwise: a composition root (:mod:`rig.composition`) wires the simulator in
by registering a *provider* for each section (:func:`register_provider`), a function that imports the
owner of the schema. :func:`section` calls it the first time a rig file has that section, and refuses
the section in a program no root has wired (:class:`SectionUnavailable`, which the loader reports on the
section's line), even when the simulator was imported: a rig file loads with the same answer whatever
was imported before. A hardware-only installation still loads hardware rig files."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

#: the rig file's top-level sections whose schema another package provides (rig-file/1, docs/rig-file.md)
SECTION_NAMES: tuple[str, ...] = ("sim", "faults")


@dataclass(frozen=True)
class Section:
    """A registered section: its pydantic model and the rig kinds it belongs to (None: any)."""

    name: str
    model: type
    kinds: tuple[str, ...] | None = None
    doc: str = ""


_REGISTRY: dict[str, Section] = {}
#: section name -> the function that makes its schema registered (imports its owner); a composition root fills it
_PROVIDERS: dict[str, Callable[[], object]] = {}


def register_section(name: str, model: type, *, kinds: tuple[str, ...] | None = None, doc: str = "") -> None:
    """Validate the rig file's top-level ``name:`` section with ``model`` from now on."""
    _REGISTRY[name] = Section(name, model, kinds, doc)


def register_provider(name: str, provider: Callable[[], object]) -> None:
    """Call ``provider()`` when section ``name`` is first needed and its schema is not registered yet: the
    provider imports the package that owns the schema, whose import registers it (:func:`register_section`).
    Called by a composition root (:mod:`rig.composition`); calling it again replaces the provider."""
    _PROVIDERS[name] = provider


def section_names() -> list[str]:
    """Every section a rig file may have beyond the core keys (named by the format, provided or registered)."""
    return sorted(set(SECTION_NAMES) | set(_PROVIDERS) | set(_REGISTRY))


class SectionUnavailable(LookupError):
    """No schema of a section can be had here: no provider is wired, or it cannot be imported (e.g. an
    installation without the simulator)."""


def section(name: str) -> Section:
    """The registered schema of section ``name``, calling its provider on first use.

    A section the format names (:data:`SECTION_NAMES`) is available only once a composition root has wired
    its provider in, even when its owner was imported already: a rig file loads with the same answer
    whatever the program imported before."""
    if name in SECTION_NAMES and name not in _PROVIDERS:
        raise SectionUnavailable(f"no provider of the {name!r} section is wired into this program (the composition "
                                 "root does it: rig.composition.wire())")
    if name not in _REGISTRY and name in _PROVIDERS:
        provider = _PROVIDERS[name]
        try:
            provider()
        except ImportError as exc:
            raise SectionUnavailable(f"its schema's provider ({provider.__module__}.{provider.__qualname__}) "
                                     f"cannot be imported here ({exc})") from None
    if name not in _REGISTRY:
        raise SectionUnavailable(f"no schema is registered for the {name!r} section")
    return _REGISTRY[name]
