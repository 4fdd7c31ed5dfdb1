"""Validating the ``rig-procedure/1`` and ``rig-file/1`` documents (pydantic v2) into one-line RigInputErrors.

The field types (:func:`number`, :func:`choice`, :func:`flag`, :func:`text`, :func:`label`), the
:class:`Strict` mapping model and :func:`fail` are the dialect every YAML format shares,
:mod:`calib.file.fields` (the rig's schemas import them from there). :func:`validate_document` parses
a YAML text with the one guarded loader (:mod:`calib.file.yamlsafe`) and validates it;
:func:`validate_located` and :func:`validate_plain` turn the first pydantic error into a one-line
:class:`~rig.errors.RigInputError` ``file:line: key.path: message`` by
:func:`calib.file.fields.describe`, with the lines of the loader's
:class:`~calib.file.yamlsafe.LineMap`.
"""

from __future__ import annotations

from typing import Any

from pydantic import TypeAdapter, ValidationError

from calib.file import yamlsafe
from calib.file.fields import FROM_FILE, describe
from rig.config.yamlload import input_error
from rig.errors import RigInputError

__all__ = ["adapter", "validate_document", "validate_located", "validate_plain"]

_ADAPTERS: dict[Any, TypeAdapter] = {}


def adapter(model) -> TypeAdapter:
    if model not in _ADAPTERS:
        _ADAPTERS[model] = TypeAdapter(model)
    return _ADAPTERS[model]


def validate_document(model, text: str, path: str, expected: str):
    """Parse YAML ``text`` (the hostile-YAML guards) and validate the whole document as ``model``;
    return (document, line marks, validated model). ``expected`` says what the top level must be."""
    try:
        doc, lines = yamlsafe.load_located(text)
    except yamlsafe.HostileYaml as exc:
        raise input_error(exc, path) from None
    if not isinstance(doc, dict):
        raise RigInputError(path, 1, None, expected)
    return doc, lines, validate_located(model, doc, path=path, loc=lines)


def validate_located(model, value, *, path: str, loc, doc=None, prefix: tuple = ()):
    """Validate ``value`` (``doc`` walked along ``prefix`` gives it) as ``model``; errors become one line."""
    try:
        return adapter(model).validate_python(value, context=FROM_FILE)
    except ValidationError as exc:
        line, key, message = describe(exc, value if doc is None else doc, loc, prefix=prefix)
        raise RigInputError(path, line or (1 if path else None), key, message) from None


def validate_plain(model, value, where: str):
    """Validate ``value`` (not from a file: no lines) as ``model``; errors name ``where.key.path``."""
    try:
        return adapter(model).validate_python(value)
    except ValidationError as exc:
        _, key, message = describe(exc, value, root=where)
        raise RigInputError(None, None, key, message) from None
