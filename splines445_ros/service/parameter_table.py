"""
The parameter table of a node: one row per field of its config dataclass (no rclpy).

Holds :func:`parameter`, with which every field of the nodes' configs
(:class:`~.planner_config.PlannerConfig`, :class:`~.arm_sim_config.ArmSimConfig`)
is declared, and what is read from those rows: the value declared to ROS,
the check of a value against the row's bounds or choices, the constraint
text of the ROS descriptor, and the parameter tables of ``doc/nodes.md``.

Modelled on the YAML of ros2_controllers' generate_parameter_library (per
parameter: type, default_value, description, validation), in Python: the
field is the row.  Its type is that of the default; its default the
dataclass default; the rest lives in the field's metadata (a :class:`Row`):

* ``description``: the ROS descriptor's description and the "meaning" of
  the table in ``doc/nodes.md`` (Markdown code spans read well in both);
* ``declared``: the value declared to ROS when it is a "not set" value
  that the config resolves (``joint_names`` ``['']``, limits ``[0.0]``:
  ROS parameter overrides cannot carry an empty array);
* validation: ``low`` / ``high`` bounds (``low_open`` / ``high_open`` for
  strict ones), a ``special`` value allowed besides them or a meaning of
  the bound (``(-1, 'auto')``, ``(0.0, 'no limit')``), ``unit`` and
  ``note`` for the message, or ``choices`` (with ``choices_note``), and
  ``only_if``: the name of a config attribute, the check applying only
  when it is true.

:meth:`ValidatedConfig.check_table <.validated_config.ValidatedConfig.check_table>`
checks every row; cross-field checks stay in the configs' ``validate``.
``scripts/parameter_docs.py`` writes the doc's tables (:func:`rewrite_tables`).
"""

from dataclasses import dataclass, field, fields
import math
import re
from typing import Any, Optional, Tuple

from ..robot.user_text import show

ROW = 'parameter_table.row'  # the key of a field's Row in its metadata


@dataclass(frozen=True)
class Row:
    """What a field states besides its name, type and default (see the module)."""

    description: str
    declared: Any = None
    low: Optional[float] = None
    high: Optional[float] = None
    low_open: bool = False
    high_open: bool = False
    special: Optional[Tuple[Any, str]] = None
    unit: str = ''
    note: str = ''
    choices: Optional[Tuple[str, ...]] = None
    choices_note: str = ''
    only_if: str = ''


def parameter(default, description, **row):
    """
    Return a dataclass field with ``default`` whose metadata is the table row.

    ``row``: the other :class:`Row` entries, by name (``low``, ``high``,
    ``choices``, ``unit``, ``declared``, ...).
    """
    if (row.get('low_open') and (row.get('low') != 0.0 or row.get('high') is not None)
            or row.get('high_open') and row.get('high') is None):
        raise ValueError('low_open needs low 0 and no high; high_open needs a high')
    return field(default=default, metadata={ROW: Row(description, **row)})


def row_of(config_field):
    """Return the Row of a config dataclass field."""
    return config_field.metadata[ROW]


def rows(config_cls):
    """Return (field, Row) of every field of ``config_cls``, in field order."""
    return [(f, row_of(f)) for f in fields(config_cls)]


def declared_value(config_field):
    """Return the value a field is declared with to ROS: its "not set" value, or the default."""
    declared = row_of(config_field).declared
    return config_field.default if declared is None else declared


def declared_values(config_cls):
    """Return every parameter's declared value, by name."""
    return {f.name: declared_value(f) for f in fields(config_cls)}


def not_set_values(config_cls):
    """Return the declared "not set" values (the fields with one), by name."""
    return {f.name: r.declared for f, r in rows(config_cls) if r.declared is not None}


def _bounds_text(row):
    """Return the row's numeric validation as words ('' when it has none)."""
    if row.low is None and row.high is None:
        return ''
    low = -math.inf if row.low is None else row.low
    if row.high is not None:
        text = (f'in [{low:g}, {row.high:g}' + (')' if row.high_open else ']')
                + (f' {row.unit}' if row.unit else '') + (f' ({row.note})' if row.note else ''))
        if row.special is not None and not _within(row, row.special[0]):
            text += f', or {row.special[0]:g} ({row.special[1]})'
        return text
    if row.low_open:
        return 'positive and finite'
    if row.special is not None:
        said = [row.unit, f'{row.special[0]:g} = {row.special[1]}']
        return f'>= {low:g} and finite (' + '; '.join(s for s in said if s) + ')'
    return f'at least {low:g}' + (f' {row.unit}' if row.unit else '')


def _within(row, value):
    low = -math.inf if row.low is None else row.low
    high = math.inf if row.high is None else row.high
    return (math.isfinite(value) and (value > low if row.low_open else value >= low)
            and (value < high if row.high_open else value <= high))


def constraint_text(row):
    """Return the row's validation as words, for the descriptor and the doc ('' if none)."""
    if row.choices is not None:
        return (f'one of {list(row.choices)}'
                + (f' ({row.choices_note})' if row.choices_note else ''))
    return _bounds_text(row)


def table_error(name, value, row):
    """Return why ``value`` breaks the row's bounds or choices (the ValueError text), or None."""
    if row.choices is not None:
        if value in row.choices:
            return None
        return (f'{name} must be one of {list(row.choices)}'
                + (f' ({row.choices_note})' if row.choices_note else '')
                + f', got {show(value)}')
    if row.low is None and row.high is None:
        return None
    if _within(row, value) or (row.special is not None and value == row.special[0]):
        return None
    return f'{name} = {value}: must be {_bounds_text(row)}'


def type_name(default):
    """Return the ROS parameter type of a default, as the doc names it."""
    if isinstance(default, bool):
        return 'bool'
    for kind, name in ((int, 'int'), (float, 'double'), (str, 'string')):
        if isinstance(default, kind):
            return name
    if isinstance(default, tuple):
        return 'string[]' if default and isinstance(default[0], str) else 'double[]'
    raise TypeError(f'no parameter type for default {default!r}')


def _value_text(value):
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return value or '""'
    if isinstance(value, tuple):
        return repr(list(value))
    return repr(value)


def default_text(config_field):
    """Return the doc's default of a field: its value, or "not set" with the declared one."""
    declared = row_of(config_field).declared
    if declared is not None:
        return f'not set (`{_value_text(declared)}`)'
    return f'`{_value_text(config_field.default)}`'


def _cell(text):
    return text.replace('|', '\\|')


def markdown_table(config_cls):
    """Return the Markdown table of ``config_cls``'s parameters (lines, no final newline)."""
    lines = ['| parameter | type | default | valid | meaning |', '|---|---|---|---|---|']
    for f, row in rows(config_cls):
        valid = constraint_text(row)
        lines.append(f'| `{f.name}` | {type_name(f.default)} | {default_text(f)} | '
                     f'{_cell(valid)} | {_cell(row.description)} |')
    return '\n'.join(lines)


BEGIN = '<!-- parameters: {} -->'
END = '<!-- end parameters -->'
_BLOCK = re.compile(r'^<!-- parameters: (\S+) -->\n.*?^<!-- end parameters -->$',
                    re.MULTILINE | re.DOTALL)


def rewrite_tables(text, configs):
    """
    Return ``text`` (a Markdown page) with its generated parameter tables rewritten.

    A table sits between ``<!-- parameters: NAME -->`` and ``<!-- end
    parameters -->``; ``configs`` maps every NAME to its config class.
    ValueError when a NAME is unknown or a configured one has no table.
    """
    found = []

    def table(match):
        name = match.group(1)
        if name not in configs:
            raise ValueError(f'no config for the parameter table {name!r}')
        found.append(name)
        return f'{BEGIN.format(name)}\n\n{markdown_table(configs[name])}\n\n{END}'

    rewritten = _BLOCK.sub(table, text)
    missing = sorted(set(configs) - set(found))
    if missing:
        raise ValueError(f'no parameter table for {missing} (expected {BEGIN.format("NAME")} '
                         f'... {END})')
    return rewritten
