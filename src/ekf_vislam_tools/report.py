"""Markdown tables for the benchmark and soak reports."""


def fmt(value, spec):
    """`value` formatted with `spec`, or '-' when it is None (a figure that does not apply)."""
    return '-' if value is None else format(value, spec)


def markdown_table(header, rows):
    """header: column titles; rows: lists of already formatted cells."""
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    lines += ['| ' + ' | '.join(str(cell) for cell in row) + ' |' for row in rows]
    return '\n'.join(lines)
