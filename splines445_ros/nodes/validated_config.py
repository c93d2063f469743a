"""Base of the nodes' frozen config dataclasses (pure Python, no rclpy)."""


class ValidatedConfig:
    """Build a config from parameter values and validate it (subclasses: ``validate``)."""

    @classmethod
    def from_values(cls, values):
        """Build and validate a config from a dict of parameter values (ValueError)."""
        config = cls(**{k: (tuple(v) if isinstance(v, (list, tuple)) else v)
                        for k, v in values.items()})
        config.validate()
        return config

    def validate(self):
        """Raise ValueError with the reason when any value is unusable."""
        raise NotImplementedError
