"""The report's text: numbers with their units, Markdown tables (every view's report section writes with these)."""
from __future__ import annotations

import numpy as np

from ..units import in_units, velocity_unit

__all__ = ["length", "speed", "rate", "md_table"]


def length(cal, px):
    """``"12.3 px"``, or ``"12.3 px (2.46 µm)"`` when the movie is calibrated."""
    text = f"{px:.3g} px"
    return text + f" ({cal.length(px):.3g} {cal.length_label})" if cal.has_length else text


def speed(cal, px_per_frame):
    """``"0.38 px/frame"``, with µm/min (the calibration's units) when the movie is calibrated."""
    text = f"{px_per_frame:.3g} px/frame"
    if cal.has_length or cal.has_time:
        text += f" ({cal.length(px_per_frame) / cal.frame_interval:.3g} {cal.length_label}/{cal.time_unit})"
    return text


def rate(cal, value, length_power=1):
    """A velocity (``length_power`` 1, px/frame) or a rate (0, 1/frame) as text, also in the calibration's units."""
    text = f"{value:.3g} {'px/frame' if length_power else '1/frame'}"
    if not (cal.has_time or (length_power and cal.has_length)):  # nothing to convert
        return text
    unit = velocity_unit(cal) if length_power else f"1/{cal.time_unit if cal.has_time else 'frame'}"
    return text + f" ({float(in_units(value, cal, length_power, -1)):.3g} {unit})"


def md_table(df, floatfmt="{:.4g}"):
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return "" if not np.isfinite(v) else floatfmt.format(v)
        return str(v)

    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines)
