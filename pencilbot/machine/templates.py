"""Profile templates filled by a substitution that can only name plain fields.

A plotter profile is data: its pen commands, header and footer are text with ``{field}``
placeholders such as ``"M3 S{up}"``. ``str.format`` would also accept ``{up.__class__}``,
``{up[0]}``, ``{0}``, ``{up!r}`` or nested specs, which let a file reach into Python objects.
:class:`FieldFormatter` accepts only bare names from a fixed set, with at most a ``.Nf``
precision, and :func:`check_template` applies the same rules when a profile is loaded, so a bad
template is refused before anything is written.
"""

from __future__ import annotations

import re
import string
from collections.abc import Iterable, Mapping

# ``{up:.0f}`` or ``{up:.3f}``: a fixed number of decimals and nothing else.
_ALLOWED_SPEC = re.compile(r"^\.[0-6]f$")


class TemplateError(ValueError):
    """A template uses something other than plain named fields; ``str()`` says what."""


class FieldFormatter(string.Formatter):
    """``string.Formatter`` restricted to named fields from ``allowed``.

    Parameters
    ----------
    allowed : iterable of str
        Field names a template may use.
    """

    def __init__(self, allowed: Iterable[str]) -> None:
        super().__init__()
        self.allowed = frozenset(allowed)

    def check(self, template: str) -> None:
        """Raise :class:`TemplateError` unless every placeholder is an allowed plain field."""
        try:
            parts = list(self.parse(template))
        except ValueError as exc:  # unbalanced braces
            raise TemplateError(f"{exc}; write a literal brace as {{{{ or }}}}") from None
        for _literal, field, spec, conversion in parts:
            if field is None:
                continue
            self._check_field(field)
            if conversion is not None:
                raise TemplateError(f"{{{field}!{conversion}}} uses a conversion; write {{{field}}}")
            if spec and not _ALLOWED_SPEC.match(spec):
                raise TemplateError(
                    f"{{{field}:{spec}}} has format spec {spec!r}; only a precision such as "
                    f"{{{field}:.1f}} is allowed"
                )

    def fill(self, template: str, values: Mapping[str, object]) -> str:
        """The template with its fields replaced by ``values`` (checked first)."""
        self.check(template)
        return self.vformat(template, (), values)

    def _check_field(self, field: str) -> None:
        if not field.isidentifier():
            raise TemplateError(
                f"{{{field}}} is not a plain field name (no attribute, index or position access); "
                f"use one of {self._names()}"
            )
        if field not in self.allowed:
            raise TemplateError(f"{{{field}}} is not a known field; use one of {self._names()}")

    def _names(self) -> str:
        return ", ".join(f"{{{name}}}" for name in sorted(self.allowed))

    def get_field(self, field_name, args, kwargs):  # noqa: D102 - string.Formatter hook
        # Second line of defence: fill() checks first, but never resolve attributes or indices.
        self._check_field(field_name)
        return kwargs[field_name], field_name


def check_template(template: str, allowed: Iterable[str]) -> None:
    """Raise :class:`TemplateError` if ``template`` uses anything but ``allowed`` plain fields."""
    FieldFormatter(allowed).check(template)


def fill_template(template: str, values: Mapping[str, object]) -> str:
    """Fill ``template`` from ``values``; only the names in ``values`` may appear."""
    return FieldFormatter(values).fill(template, values)
