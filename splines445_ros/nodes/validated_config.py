"""Base of the nodes' frozen config dataclasses (pure Python, no rclpy)."""

from dataclasses import fields, replace
import math


class ValidatedConfig:
    """Build a config from parameter values and validate it (subclasses: ``validate``)."""

    @classmethod
    def from_values(cls, values):
        """Build and validate a config from a dict of parameter values (ValueError)."""
        config = cls(**{k: (tuple(v) if isinstance(v, (list, tuple)) else v)
                        for k, v in values.items()})
        # String parameters are declared with dynamic typing (so that a number
        # typed on the command line arrives at all): check the type here.
        for field in fields(cls):
            value = getattr(config, field.name)
            if isinstance(field.default, str) and not isinstance(value, str):
                raise ValueError(f'{field.name} must be a string, got {value!r}')
        # Arrays that default to empty are declared with dynamic typing too
        # (rclpy types an empty default as a byte array): numbers only, as floats.
        changes = {}
        for field in fields(cls):
            if field.default == ():
                value = getattr(config, field.name)
                if not isinstance(value, tuple) or any(
                        isinstance(v, (bool, str, bytes)) or not isinstance(v, (int, float))
                        for v in value):
                    raise ValueError(f'{field.name} must be an array of numbers, got {value!r}')
                changes[field.name] = tuple(float(v) for v in value)
        if changes:
            config = replace(config, **changes)
        config.validate()
        return config

    def validate(self):
        """Raise ValueError with the reason when any value is unusable."""
        raise NotImplementedError

    def require_in_range(self, name, low, high, unit=''):
        """Raise ValueError unless the field ``name`` is finite and in [low, high]."""
        value = getattr(self, name)
        if not (math.isfinite(value) and low <= value <= high):
            raise ValueError(f'{name} = {value}: must be in [{low:g}, {high:g}]'
                             + (f' {unit}' if unit else ''))

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
