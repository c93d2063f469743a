"""
ROS parameters backed by a validated, immutable config dataclass.

Every field of the dataclass becomes a parameter declared with a descriptor
(type and description).  ``set_parameters`` builds a new config from the
current values overlaid with the request; if the config's ``from_values``
raises ValueError, the request is rejected with that reason and nothing changes.
The node's ``on_change(new_config)`` runs before the new config is in force
and may reject it the same way (raise ValueError, leaving its state as it was).

String parameters accept numbers as users type them: ``-p method:=434``
arrives as an INTEGER, so string fields are declared with dynamic typing and
a number given for one is stored as its string (``'434'``), at start-up and
on every ``set_parameters``; any other type is rejected by validation with
the reason.  Array fields whose default is empty (``min_position``) are
dynamically typed as well, so ``[-1, 1]`` typed as integers is accepted.
"""

from dataclasses import fields

from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.parameter import Parameter


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


def _numeric_string(parameter):
    """Return ``parameter`` as a string parameter if a number was given, else None."""
    value = parameter.value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return Parameter(parameter.name, Parameter.Type.STRING, str(value))
    return None


class ConfigParameters:
    """Declare ``config_cls``'s fields on ``node`` and keep ``self.config`` valid."""

    def __init__(self, node, config_cls, descriptions, on_change=None, on_reject=None):
        """
        Declare, read and validate (ValueError on a bad start-up value).

        ``on_change(config)`` applies an accepted config (a ValueError from it
        rejects the update); ``on_reject(reason, names)`` reports a rejected
        update (the nodes put it on ``~/status``).
        """
        self._node = node
        self._config_cls = config_cls
        self._on_change = on_change
        self._on_reject = on_reject
        defaults = config_cls()
        self.names = [f.name for f in fields(config_cls)]
        self._string_names = {n for n in self.names if isinstance(getattr(defaults, n), str)}
        # rclpy types an empty array default as a byte array: such arrays are
        # declared with dynamic typing and checked by the config instead.
        dynamic = self._string_names | {n for n in self.names if getattr(defaults, n) == ()}
        for name in self.names:
            default = getattr(defaults, name)
            if name in dynamic:
                descriptor = ParameterDescriptor(
                    name=name, dynamic_typing=True, description=descriptions[name])
            else:
                descriptor = ParameterDescriptor(
                    name=name, type=_parameter_type(default), description=descriptions[name])
            node.declare_parameter(
                name, list(default) if isinstance(default, tuple) else default, descriptor)
        typed = [p for p in (node.get_parameter(n) for n in self._string_names)
                 if _numeric_string(p) is not None]
        if typed:
            node.set_parameters([_numeric_string(p) for p in typed])
        self.config = config_cls.from_values(
            {name: node.get_parameter(name).value for name in self.names})
        node.add_pre_set_parameters_callback(self._numbers_as_strings)
        node.add_on_set_parameters_callback(self._on_set_parameters)

    def _numbers_as_strings(self, parameters):
        return [(_numeric_string(p) if p.name in self._string_names else None) or p
                for p in parameters]

    def _on_set_parameters(self, parameters):
        values = {name: getattr(self.config, name) for name in self.names}
        for parameter in parameters:
            if parameter.name in values:
                values[parameter.name] = parameter.value
        try:
            new = self._config_cls.from_values(values)
            if self._on_change is not None:
                # The node applies the config first; a ValueError (e.g. a model
                # file that does not load) rejects it and the old one stays.
                self._on_change(new)
        except (TypeError, ValueError) as exc:
            reason = f'rejected: {exc}'
            self._node.get_logger().warning(reason)
            if self._on_reject is not None:
                self._on_reject(reason, [p.name for p in parameters])
            return SetParametersResult(successful=False, reason=reason)
        self.config = new
        return SetParametersResult(successful=True)
