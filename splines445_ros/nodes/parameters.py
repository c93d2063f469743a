"""
ROS parameters backed by a validated, immutable config dataclass.

Every field of the dataclass becomes a parameter declared with a descriptor
(type and description).  ``set_parameters`` builds a new config from the
current values overlaid with the request; if the config's ``from_values``
raises ValueError, the request is rejected with that reason and nothing changes.
"""

from dataclasses import fields

from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult


def _parameter_type(default):
    if isinstance(default, bool):
        return ParameterType.PARAMETER_BOOL
    if isinstance(default, int):
        return ParameterType.PARAMETER_INTEGER
    if isinstance(default, float):
        return ParameterType.PARAMETER_DOUBLE
    if isinstance(default, str):
        return ParameterType.PARAMETER_STRING
    if isinstance(default, tuple) and default and isinstance(default[0], str):
        return ParameterType.PARAMETER_STRING_ARRAY
    if isinstance(default, tuple):
        return ParameterType.PARAMETER_DOUBLE_ARRAY
    raise TypeError(f'no parameter type for default {default!r}')


class ConfigParameters:
    """Declare ``config_cls``'s fields on ``node`` and keep ``self.config`` valid."""

    def __init__(self, node, config_cls, descriptions, on_change=None):
        """Declare, read and validate (ValueError on a bad start-up value)."""
        self._node = node
        self._config_cls = config_cls
        self._on_change = on_change
        defaults = config_cls()
        self.names = [f.name for f in fields(config_cls)]
        for name in self.names:
            default = getattr(defaults, name)
            descriptor = ParameterDescriptor(
                name=name, type=_parameter_type(default), description=descriptions[name])
            node.declare_parameter(
                name, list(default) if isinstance(default, tuple) else default, descriptor)
        self.config = config_cls.from_values(
            {name: node.get_parameter(name).value for name in self.names})
        node.add_on_set_parameters_callback(self._on_set_parameters)

    def _on_set_parameters(self, parameters):
        values = {name: getattr(self.config, name) for name in self.names}
        for parameter in parameters:
            if parameter.name in values:
                values[parameter.name] = parameter.value
        try:
            new = self._config_cls.from_values(values)
        except (TypeError, ValueError) as exc:
            reason = f'rejected: {exc}'
            self._node.get_logger().warning(reason)
            return SetParametersResult(successful=False, reason=reason)
        self.config = new
        if self._on_change is not None:
            self._on_change(new)
        return SetParametersResult(successful=True)
