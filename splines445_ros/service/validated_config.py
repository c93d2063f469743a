"""
Base of the nodes' frozen config dataclasses (pure Python, no rclpy).

:class:`ValidatedConfig` builds a config from parameter values (type checks
of the dynamically typed parameters), resolves its "not set" values and
validates it: the bounds and choices of its parameter table
(:meth:`~ValidatedConfig.check_table`, see :mod:`.parameter_table`) and the
subclass's own cross-field checks (``validate``).
"""

import array
from dataclasses import fields, replace
import math

from .parameter_table import rows, table_error
from ..robot.user_text import show


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class ValidatedConfig:
    """Build a config from parameter values and validate it (subclasses: ``validate``)."""

    @classmethod
    def from_values(cls, values):
        """Build and validate a config from a dict of parameter values (ValueError)."""
        config = cls(**{k: (tuple(v) if isinstance(v, (list, tuple, array.array)) else v)
                        for k, v in values.items()})
        # Strings, doubles and double arrays are declared with dynamic typing
        # (so that values as users type them arrive at all): check the type
        # here; numbers become floats.
        changes = {}
        for field in fields(cls):
            value, default = getattr(config, field.name), field.default
            if isinstance(default, str) and not isinstance(value, str):
                raise ValueError(f'{field.name} must be a string, got {show(value)}')
            if isinstance(default, float):
                if not _is_number(value):
                    raise ValueError(f'{field.name} must be a number, got {show(value)}')
                changes[field.name] = float(value)
            if isinstance(default, tuple) and not (default and isinstance(default[0], str)):
                if not isinstance(value, tuple) or not all(_is_number(v) for v in value):
                    raise ValueError(f'{field.name} must be an array of numbers, '
                                     f'got {show(value)}')
                changes[field.name] = tuple(float(v) for v in value)
        config = replace(config, **changes).with_defaults()
        config.validate()
        return config

    def with_defaults(self):
        """Return the config with "not set" values resolved; the base class has none."""
        return self

    def validate(self):
        """Raise ValueError with the reason when any value is unusable."""
        raise NotImplementedError

    def unused(self):
        """
        Return ``{name: reason}`` for values away from their default that this mode ignores.

        Valid, but without effect where they are (a dynamic-only gain on the
        kinematic arm, a sample period with knot output): the nodes say so
        with a WARN rather than refuse them, as another mode (or a goal's
        overrides) may use them.  :meth:`_unused_where` builds it.
        """
        return {}

    def _unused_where(self, names, ignored, reason):
        """``{name: reason}`` for those of ``names`` away from their default, if ``ignored``."""
        if not ignored:
            return {}
        defaults = {f.name: f.default for f in fields(type(self))}
        return {name: reason for name in names if getattr(self, name) != defaults[name]}

    def check_table(self):
        """
        Raise ValueError unless every value is within its table row's bounds or choices.

        Rows in field order; a row with ``only_if`` is checked when that
        attribute of the config is true.
        """
        for field, row in rows(type(self)):
            if row.only_if and not getattr(self, row.only_if):
                continue
            error = table_error(field.name, getattr(self, field.name), row)
            if error:
                raise ValueError(error)

    def require_positive(self, name, count, count_text=None):
        """
        Raise ValueError unless the field ``name`` holds ``count`` positive finite values.

        ``count_text`` says how many in the error (default "<count> values").
        """
        values = getattr(self, name)
        if len(values) != count:
            raise ValueError(f'{name} needs {count_text or f"{count} values"}, '
                             f'got {len(values)}')
        for i, v in enumerate(values):
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f'{name}[{i}] = {v}: must be positive and finite')
