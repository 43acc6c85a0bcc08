"""Markdown tables for the benchmark and soak reports, and the machine they ran on."""
import os


def fmt(value, spec):
    """`value` formatted with `spec`, or '-' when it is None (a figure that does not apply)."""
    return '-' if value is None else format(value, spec)


def markdown_table(header, rows):
    """header: column titles; rows: lists of already formatted cells."""
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    lines += ['| ' + ' | '.join(str(cell) for cell in row) + ' |' for row in rows]
    return '\n'.join(lines)


def machine_description():
    """One line naming the machine a measurement ran on: CPU model, cores, load average at the
    start (machines of one kind differ 2-3x in speed; figures compare within one run)."""
    model = 'unknown CPU'
    try:
        with open('/proc/cpuinfo') as f:
            for line in f:
                if line.startswith('model name'):
                    model = line.split(':', 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        load = '%.2f' % os.getloadavg()[0]
    except OSError:
        load = '-'
    return 'machine: %s, %d cores, load average %s at the start' % (model, os.cpu_count() or 0,
                                                                     load)
