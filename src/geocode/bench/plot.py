"""A small line plot as SVG text (no plotting library): lines of points with 95% intervals as
error bars, dashed lines without points (a fit), a log or linear x axis, labelled axes and a
legend; readable at 640 x 400.

    svg = line_plot([Series("network", xs, means, lows, highs)], "training shapes", "distance")
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from html import escape

WIDTH, HEIGHT = 640, 400
LEFT, RIGHT, TOP, BOTTOM = 78, 20, 36, 52     # margins around the plot area, px
COLOURS = ("#1f5fa8", "#c2410c", "#15803d", "#7e22ce")
CAP = 4                                        # half the width of an error bar's caps, px
DASH = ' stroke-dasharray="6 4"'


@dataclass(frozen=True)
class Series:
    """Measured points with their intervals; or, without intervals, a dashed line (a fit)."""
    name: str
    x: Sequence[float]
    y: Sequence[float]
    low: Sequence[float] | None = None     # the interval around each y
    high: Sequence[float] | None = None
    colour: str = COLOURS[0]

    @property
    def dashed(self) -> bool:
        return self.low is None


@dataclass(frozen=True)
class Axis:
    """Data values lo .. hi onto pixels start .. end (end < start for y), log or linear, with
    labelled ticks at `ticks`."""
    lo: float
    hi: float
    start: float
    end: float
    log: bool = False
    ticks: tuple[float, ...] = ()

    def __call__(self, value: float) -> float:
        f = math.log if self.log else float
        share = 0.5 if self.hi == self.lo else (f(value) - f(self.lo)) / (f(self.hi) - f(self.lo))
        return self.start + share * (self.end - self.start)


def x_axis(series: Sequence[Series], log: bool) -> Axis:
    """The x axis over every series' x, with a margin of 5% of the plot's width each side;
    ticks at the measured points' x values and at the end of each dashed line."""
    xs = [x for s in series for x in s.x]
    ticks = sorted({v for s in series for v in ([s.x[-1]] if s.dashed else s.x)})
    width = WIDTH - LEFT - RIGHT
    return Axis(min(xs), max(xs), LEFT + 0.05 * width, WIDTH - RIGHT - 0.05 * width, log, tuple(ticks))


def y_axis(series: Sequence[Series]) -> Axis:
    """The y axis from the nice tick at or below the lowest interval to the one at or above
    the highest."""
    ticks = nice_ticks(min(v for s in series for v in (s.y if s.dashed else s.low)),
                       max(v for s in series for v in (s.y if s.dashed else s.high)))
    return Axis(ticks[0], ticks[-1], HEIGHT - BOTTOM, TOP, ticks=tuple(ticks))


def nice_ticks(lo: float, hi: float, count: int = 5) -> list[float]:
    """Round tick values (steps of 1, 2 or 5 times a power of ten) covering lo .. hi."""
    if hi <= lo:
        lo, hi = lo - abs(lo) * 0.1 - 1e-12, hi + abs(hi) * 0.1 + 1e-12
    raw = (hi - lo) / count
    power = 10 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    first = math.floor(lo / step + 1e-6)      # a value a rounding error past a tick takes that tick
    last = math.ceil(hi / step - 1e-6)
    return [round(k * step, 12) for k in range(first, last + 1)]


def line_plot(series: Sequence[Series], x_label: str, y_label: str, title: str = "", log_x: bool = True) -> str:
    """The SVG document: each series a line through its points, each measured point a circle
    with its interval as an error bar."""
    x, y = x_axis(series, log_x), y_axis(series)
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" '
             f'viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="12">',
             f'<rect width="{WIDTH}" height="{HEIGHT}" fill="white"/>',
             text(WIDTH / 2, 20, title, size=14),
             *frame(x, y, x_label, y_label)]
    for k, s in enumerate(series):
        parts += draw_series(s, x, y)
        parts += legend_entry(k, s)
    return "\n".join([*parts, "</svg>"]) + "\n"


def frame(x: Axis, y: Axis, x_label: str, y_label: str) -> list[str]:
    """The plot area's box, grid lines, tick labels and axis labels."""
    left, right, bottom, top = LEFT, WIDTH - RIGHT, HEIGHT - BOTTOM, TOP
    out = [f'<rect x="{left}" y="{top}" width="{right - left}" height="{bottom - top}" fill="none" stroke="#444"/>']
    for v in y.ticks:
        py = y(v)
        out.append(f'<line x1="{left}" y1="{py:.1f}" x2="{right}" y2="{py:.1f}" stroke="#ddd"/>')
        out.append(text(left - 6, py + 4, f"{v:g}", anchor="end"))
    for v in x.ticks:
        px = x(v)
        out.append(f'<line x1="{px:.1f}" y1="{bottom}" x2="{px:.1f}" y2="{bottom + 5}" stroke="#444"/>')
        out.append(text(px, bottom + 18, f"{v:g}"))
    out.append(text((left + right) / 2, HEIGHT - 10, x_label))
    out.append(text(16, (top + bottom) / 2, y_label, rotate=True))
    return out


def draw_series(s: Series, x: Axis, y: Axis) -> list[str]:
    points = " ".join(f"{x(a):.1f},{y(b):.1f}" for a, b in zip(s.x, s.y, strict=True))
    colour = s.colour
    out = [f'<polyline points="{points}" fill="none" stroke="{colour}" stroke-width="2"{DASH * s.dashed}/>']
    if s.dashed:
        return out
    for a, b, lo, hi in zip(s.x, s.y, s.low, s.high, strict=True):
        px, p_lo, p_hi = x(a), y(lo), y(hi)
        out.append(f'<path d="M{px:.1f},{p_lo:.1f}V{p_hi:.1f}M{px - CAP:.1f},{p_lo:.1f}H{px + CAP:.1f}'
                   f'M{px - CAP:.1f},{p_hi:.1f}H{px + CAP:.1f}" stroke="{colour}" stroke-width="1.5" fill="none"/>')
        out.append(f'<circle cx="{px:.1f}" cy="{y(b):.1f}" r="4" fill="{colour}"><title>{escape(s.name)}: '
                   f'x {a:g}, y {b:.4g} [{lo:.4g}, {hi:.4g}]</title></circle>')
    return out


def legend_entry(k: int, s: Series) -> list[str]:
    """Entry k of the legend, in the plot area's top right corner."""
    px, py = WIDTH - RIGHT - 250, TOP + 16 + 18 * k
    return [f'<line x1="{px}" y1="{py}" x2="{px + 24}" y2="{py}" stroke="{s.colour}" stroke-width="2"'
            f'{DASH * s.dashed}/>', text(px + 30, py + 4, s.name, anchor="start")]


def text(x: float, y: float, content: str, anchor: str = "middle", size: int = 12, rotate: bool = False) -> str:
    turn = f' transform="rotate(-90 {x:.1f} {y:.1f})"' if rotate else ""
    return (f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}" font-size="{size}"{turn}>'
            f"{escape(content)}</text>")
