"""
ROS parameters backed by a validated, immutable config dataclass.

Every field of the dataclass becomes a parameter declared with a descriptor:
its type, and the description and validation of the field's row of the
parameter table (:mod:`..service.parameter_table`), the bounds or choices as
``additional_constraints`` text (not as ``floating_point_range`` or
``integer_range``: rclpy would then refuse a value outside them itself, with
its own reason, and ``~/status`` would not hear of it).  The declared value
is the row's "not set" value where it has one.  ``set_parameters`` builds a new config from the
current values overlaid with the request; if the config's ``from_values``
raises ValueError, the request is rejected with that reason and nothing changes.
The node's ``on_change(new_config)`` runs before the new config is in force
and may reject it the same way (raise ValueError, leaving its state as it was).

Parameters accept values as users type them: ``-p method:=434`` arrives as
an INTEGER, ``-p waypoint_tolerance:=0`` too, ``-p max_velocity:=[2,2,2]``
as an INTEGER_ARRAY and ``ros2 param set`` sends arrays as ``array.array``.
So string, double and double-array fields are declared with dynamic typing,
and a number given for one is stored in the field's type (``'434'``,
``0.0``, ``[2.0, 2.0, 2.0]``), at start-up and on every ``set_parameters``;
any other type is rejected by validation with the reason.
"""

import array
from dataclasses import fields

from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.parameter import Parameter

from ..robot.user_text import show
from ..service.parameter_table import constraint_text, declared_values, row_of


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


def _kind(default):
    """Return how values for a field with this default are normalised, or None (typed)."""
    if isinstance(default, bool) or isinstance(default, int):
        return None
    if isinstance(default, str):
        return 'string'
    if isinstance(default, float):
        return 'double'
    if isinstance(default, tuple) and not (default and isinstance(default[0], str)):
        return 'double_array'
    return None


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _normalised(parameter, kind):
    """
    Return ``parameter`` in its field's canonical type, or None when it is not a number.

    A number for a string field becomes its string (``-p method:=434``), an
    integer for a double field a double (``-p waypoint_tolerance:=0``),
    integers (or an ``array.array`` from the parameter service) for a double
    array field doubles (``-p max_velocity:=[2,2,2]``), and "not set" for a
    double array field (``min_position: []`` in a params file) the empty
    array.
    """
    value = parameter.value
    if kind == 'double_array' and parameter.type_ == Parameter.Type.NOT_SET:
        # An empty array from a params file or -p (rclpy types it as "not set"), or a
        # `ros2 param delete`: the empty array, which the config accepts or refuses.
        return Parameter(parameter.name, Parameter.Type.DOUBLE_ARRAY, [])
    if kind == 'string' and _is_number(value):
        return Parameter(parameter.name, Parameter.Type.STRING, str(value))
    if kind == 'double' and _is_number(value) and not isinstance(value, float):
        return Parameter(parameter.name, Parameter.Type.DOUBLE, float(value))
    if (kind == 'double_array' and isinstance(value, (list, tuple, array.array))
            and all(_is_number(v) for v in value)
            and parameter.type_ != Parameter.Type.DOUBLE_ARRAY):
        return Parameter(parameter.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in value])
    return None


class ConfigParameters:
    """Declare ``config_cls``'s fields on ``node`` and keep ``self.config`` valid."""

    def __init__(self, node, config_cls, on_change=None, on_reject=None):
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
        table = {f.name: row_of(f) for f in fields(config_cls)}
        # Declared defaults: the dataclass's, or a "not set" value the config resolves
        # (e.g. joint_names [''] = the robot model's joints, or the planar arm's).
        declared = declared_values(config_cls)
        # Strings, doubles and double arrays are declared with dynamic typing,
        # so that values as users type them arrive at all (rclpy would refuse
        # an INTEGER for a DOUBLE, and types an empty array default as a byte
        # array); they are normalised to their field's type, and the config
        # rejects anything else with the reason.
        self._kinds = {n: _kind(getattr(defaults, n)) for n in self.names
                       if _kind(getattr(defaults, n)) is not None}
        for name in self.names:
            default = declared[name]
            text = {'description': table[name].description,
                    'additional_constraints': constraint_text(table[name])}
            if name in self._kinds:
                descriptor = ParameterDescriptor(name=name, dynamic_typing=True, **text)
            else:
                descriptor = ParameterDescriptor(
                    name=name, type=_parameter_type(default), **text)
            node.declare_parameter(
                name, list(default) if isinstance(default, tuple) else default, descriptor)
        typed = [_normalised(node.get_parameter(n), kind) for n, kind in self._kinds.items()]
        if any(p is not None for p in typed):
            node.set_parameters([p for p in typed if p is not None])
        self.config = config_cls.from_values(
            {name: node.get_parameter(name).value for name in self.names})
        self._unused = self._say_unused(self.config, {})
        node.add_pre_set_parameters_callback(self._as_field_types)
        node.add_on_set_parameters_callback(self._on_set_parameters)

    def overridden(self, values):
        """
        Return the config of the current parameters with ``values`` in their place.

        ``values`` maps parameter names to values (a request's overrides); they
        are validated as a ``set_parameters`` would be (ValueError with the
        same reason), and the node's parameters do not change.
        """
        unknown = sorted(set(values) - set(self.names))
        if unknown:
            raise ValueError(f'unknown parameters {unknown}')
        current = {name: self._node.get_parameter(name).value for name in self.names}
        current.update(values)
        return self._config_cls.from_values(current)

    def _as_field_types(self, parameters):
        return [(_normalised(p, self._kinds[p.name]) if p.name in self._kinds else None) or p
                for p in parameters]

    def _on_set_parameters(self, parameters):
        # The parameters as set (not the config, whose "not set" values are resolved).
        values = {name: self._node.get_parameter(name).value for name in self.names}
        for parameter in parameters:
            if parameter.name in values:
                values[parameter.name] = parameter.value
        try:
            new = self._config_cls.from_values(values)
            if self._on_change is not None:
                # The node applies the config first; a ValueError (e.g. a model
                # file that does not load) rejects it and the old one stays.
                self._on_change(new)
        except Exception as exc:  # noqa: B902 - a parameter must never kill the node
            # TypeError and ValueError are the config's own refusals; anything
            # else (an OverflowError or a RecursionError from a file read for
            # it) is refused all the same, with its type.
            text = str(exc) if isinstance(exc, (TypeError, ValueError)) else (
                f'{type(exc).__name__}: {exc}')
            reason = f'rejected: {text}'
            self._node.get_logger().warning(reason)
            if self._on_reject is not None:
                self._on_reject(reason, [p.name for p in parameters])
            return SetParametersResult(successful=False, reason=reason)
        self.config = new
        self._unused = self._say_unused(new, self._unused, [p.name for p in parameters])
        return SetParametersResult(successful=True)

    def _say_unused(self, config, before, names=()):
        """
        WARN of each value ``config`` ignores that ``before`` did not, or that was just set.

        Returns ``config.unused()``, the next call's ``before``.
        """
        unused = config.unused()
        for name, reason in unused.items():
            if name not in before or name in names:
                self._node.get_logger().warning(
                    f'{name} = {show(getattr(config, name))} has no effect: {reason}')
        return unused
