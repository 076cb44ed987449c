"""Draw docs/reference/frames.png: the frames, the lever arms and the triad point, as the glossary uses them.

Run from anywhere (``python docs/reference/draw_frames.py``); the PNG is written next to this script.
The drawing is deterministic: a fixed geometry, no randomness, no time stamp in the file.

Left: the navigation frame n (North-East-Down) and the body frame b (x forward, y right, z down),
turned by the attitude ``q_nb``. Right: the IMU in body axes, drawn in an oblique projection: the
reference point O, the three accelerometers' sensitive masses with their sensitive axes, the triad
point C where the normals through the masses meet, the offset r from O to C, the arms r_i from O and
d_i from C (``r_i = r + d_i``), and the rotation whose centripetal and tangential terms the arms give.
The geometry is a sketch, not to scale and not any real unit.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure  # no pyplot: no backend, no global state
from matplotlib.patches import FancyArrowPatch, Polygon

OUT = Path(__file__).with_name("frames.png")

#: The oblique projection of body (or NED) coordinates onto the page: the first axis (x forward,
#: North) recedes up and to the right at RECEDE_DEG, shortened by RECEDE; the second (y right, East)
#: points right; the third (z down, Down) points down the page.
RECEDE_DEG = 35.0
RECEDE = 0.6

#: Colours of accelerometers x, y, z (colour-blind safe: Okabe and Ito), and of the set-up.
COLOUR = {"x": "#0072B2", "y": "#D55E00", "z": "#009E73"}
SETUP = "#222222"
GREY = "#888888"

#: The sketch's geometry [mm, body axes x forward, y right, z down]: the offset r from the
#: reference point O to the triad point C, and each accelerometer's arm d_i from C (along its own
#: sensitive axis, so that the three normals meet at C, as in the paper's high-precision design).
R_OFFSET = np.array([10.0, -40.0, -50.0])
D_ARMS = {"x": np.array([70.0, 0.0, 0.0]), "y": np.array([0.0, -48.0, 0.0]), "z": np.array([0.0, 0.0, 48.0])}


def project(p) -> np.ndarray:
    """Page coordinates of a point in (first, second, third) axes: the oblique projection."""
    a = math.radians(RECEDE_DEG)
    x, y, z = p
    return np.array([y + RECEDE * x * math.cos(a), -z + RECEDE * x * math.sin(a)])


def arrow(ax, start, end, colour, *, width=1.6, style="-|>", dashed=False, scale=14, z=3):
    """An arrow between two page points."""
    ax.add_patch(
        FancyArrowPatch(
            tuple(start),
            tuple(end),
            arrowstyle=style,
            mutation_scale=scale,
            color=colour,
            lw=width,
            linestyle=(0, (5, 3)) if dashed else "-",
            shrinkA=0,
            shrinkB=0,
            zorder=z,
        )
    )


def label(ax, at, text, colour="black", *, size=12, ha="center", va="center", weight="normal", box=False):
    ax.text(
        at[0],
        at[1],
        text,
        color=colour,
        fontsize=size,
        ha=ha,
        va=va,
        weight=weight,
        zorder=6,
        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85) if box else None,
    )


def triad(ax, origin, length, names, colours, *, width=2.0, offsets=None, size=12, rotation=None):
    """Three axes from ``origin`` (a 3-vector), optionally turned by ``rotation`` [3, 3] (columns: the
    axes in the drawing's coordinates), each with its name at the tip."""
    rot = np.eye(3) if rotation is None else rotation
    o = project(origin)
    for k, (name, colour) in enumerate(zip(names, colours)):
        tip = project(origin + length * rot[:, k])
        arrow(ax, o, tip, colour, width=width)
        d = tip - o
        shift = (offsets or {}).get(k, 0.16 * d / max(np.linalg.norm(d), 1e-9) * length)
        label(ax, tip + shift, name, colour, size=size)


def rot_zyx(heading_deg, pitch_deg, roll_deg) -> np.ndarray:
    """``mat_nb = Rz(heading) Ry(pitch) Rx(roll)``: its columns are the body axes in NED."""
    h, p, r = (math.radians(v) for v in (heading_deg, pitch_deg, roll_deg))
    rz = np.array([[math.cos(h), -math.sin(h), 0], [math.sin(h), math.cos(h), 0], [0, 0, 1]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    return rz @ ry @ rx


def frames_panel(ax):
    """The navigation frame n and the body frame b at one point."""
    origin = np.zeros(3)
    triad(ax, origin, 62.0, ("N", "E", "D"), (GREY, GREY, GREY), width=1.8, size=15)
    mat_nb = rot_zyx(35.0, 12.0, 0.0)
    triad(
        ax,
        origin,
        55.0,
        ("x forward", "y right", "z down"),
        ("black",) * 3,
        width=2.6,
        size=14,
        rotation=mat_nb,
        offsets={0: np.array([16.0, 7.0]), 1: np.array([10.0, -7.0]), 2: np.array([16.0, -4.0])},
    )
    g_from, g_to = project(np.array([0.0, -40.0, 20.0])), project(np.array([0.0, -40.0, 60.0]))
    arrow(ax, g_from, g_to, GREY, width=1.6)
    label(ax, g_to + np.array([-4.0, 6.0]), "g", GREY, size=15, ha="right")
    label(
        ax,
        (-48.0, 96.0),
        "n: North-East-Down (grey)\nb: x forward, y right,\n    z down (black)",
        size=13,
        ha="left",
        va="top",
    )
    label(
        ax,
        (-48.0, -80.0),
        "attitude q_nb, scalar first,\nturns b into n:\nv_n = mat_nb @ v_b\n(here heading 35°, pitch 12°)",
        size=13,
        ha="left",
        va="top",
    )
    ax.set_xlim(-50.0, 92.0)
    ax.set_ylim(-150.0, 100.0)
    ax.set_title("frames", fontsize=15, loc="left")


def box_edges(lo, hi) -> list:
    """The twelve edges of the box [lo, hi] (3-vectors), as pairs of 3-D points."""
    corners = [np.array([x, y, z]) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    edges = []
    for i, a in enumerate(corners):
        for b in corners[i + 1 :]:
            if np.count_nonzero(a != b) == 1:
                edges.append((a, b))
    return edges


def note(ax, text, at, to, colour=SETUP, *, size=12.5, ha="left", va="center"):
    """A label at ``at`` with a thin leader line to the point ``to``."""
    ax.annotate(
        text,
        xy=tuple(to),
        xytext=tuple(at),
        color=colour,
        fontsize=size,
        ha=ha,
        va=va,
        zorder=6,
        arrowprops=dict(arrowstyle="-", color=colour, lw=0.8, shrinkA=2, shrinkB=6),
        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85),
    )


def geometry_panel(ax):
    """The reference point O, the triad point C, the masses, their arms and the rotation."""
    o3, c3 = np.zeros(3), R_OFFSET
    masses = {i: c3 + d for i, d in D_ARMS.items()}
    o, c = project(o3), project(c3)
    m = {i: project(p) for i, p in masses.items()}

    # the IMU's case, faint: a box around C and the masses
    pts = np.array([c3, *masses.values()])
    lo, hi = pts.min(axis=0) - 10.0, pts.max(axis=0) + 10.0
    top = [
        project(np.array([x, y, lo[2]])) for x, y in ((lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1]))
    ]
    ax.add_patch(Polygon(np.array(top), closed=True, fc="#f3f3f3", ec="none", zorder=0))
    for a, b in box_edges(lo, hi):
        pa, pb = project(a), project(b)
        ax.plot([pa[0], pb[0]], [pa[1], pb[1]], color="#cccccc", lw=1.0, zorder=1)
    label(
        ax,
        project(np.array([lo[0], lo[1], hi[2]])) + np.array([3.0, 4.0]),
        "IMU",
        GREY,
        size=13,
        ha="left",
        va="bottom",
    )

    # the normals: lines through each mass along its sensitive axis; they meet at C
    for i, p3 in masses.items():
        u = D_ARMS[i] / np.linalg.norm(D_ARMS[i])
        a, b = project(c3 - 16.0 * u), project(p3 + 22.0 * u)
        ax.plot([a[0], b[0]], [a[1], b[1]], color=GREY, lw=1.1, ls=":", zorder=2)

    # the arms r_i from O, dashed; d_i from C, solid; the offset r from O to C
    for i in "xyz":
        arrow(ax, o, m[i], COLOUR[i], width=1.5, dashed=True, scale=13)
        arrow(ax, c, m[i], COLOUR[i], width=2.8, scale=16, z=4)
    arrow(ax, o, c, SETUP, width=3.0, scale=17, z=4)

    # the sensitive masses and their sensitive axes u_i (double arrows along the normals)
    for i, p3 in masses.items():
        u = D_ARMS[i] / np.linalg.norm(D_ARMS[i])
        arrow(ax, project(p3 - 9.0 * u), project(p3 + 14.0 * u), COLOUR[i], width=3.4, style="<|-|>", scale=14, z=5)
        ax.plot(*m[i], "o", ms=13, mfc="white", mec=COLOUR[i], mew=2.8, zorder=6)
    ax.plot(*c, "o", ms=11, color=SETUP, zorder=6)
    ax.plot(*o, "o", ms=12, mfc="white", mec=SETUP, mew=2.6, zorder=6)
    ax.plot(*o, "+", ms=12, color=SETUP, mew=1.7, zorder=7)

    # the points and the masses, named
    label(ax, c + np.array([6.0, 6.0]), "C", SETUP, size=17, weight="bold", ha="left", va="bottom")
    label(ax, o + np.array([6.0, -4.0]), "O", SETUP, size=17, weight="bold", ha="left", va="top")
    note(ax, "accelerometer x,\nsensitive axis u_x", m["x"] + np.array([22.0, 6.0]), m["x"], COLOUR["x"])
    note(ax, "accelerometer y, u_y", m["y"] + np.array([-18.0, 26.0]), m["y"], COLOUR["y"], ha="center", va="bottom")
    note(ax, "accelerometer z, u_z", m["z"] + np.array([-30.0, -24.0]), m["z"], COLOUR["z"], ha="center", va="top")
    note(ax, "triad point C, where the\nnormals through the masses meet", (-148.0, 96.0), c, va="bottom")
    note(
        ax,
        "reference point O: a table's rotation\ncentre, a motion-capture body's\ntracked point, a vehicle's\nnavigation point",
        o + np.array([22.0, -14.0]),
        o,
        va="top",
    )

    # the arms, named
    label(ax, 0.5 * (o + c) + np.array([-8.0, -6.0]), "r", SETUP, size=16, weight="bold", box=True)
    for i, at, shift in (("x", 0.55, (6.0, 0.0)), ("y", 0.7, (-3.0, -8.0)), ("z", 0.5, (0.0, -7.0))):
        label(ax, o + at * (m[i] - o) + np.array(shift), f"r_{i}", COLOUR[i], size=15, weight="bold", box=True)
    for i, shift in (("x", (-6.0, 8.0)), ("y", (0.0, 7.0)), ("z", (-8.0, 0.0))):
        label(ax, 0.5 * (c + m[i]) + np.array(shift), f"d_{i}", COLOUR[i], size=15, weight="bold", box=True)

    # the rotation, about an axis through O (here body x)
    u = project(np.array([1.0, 0.0, 0.0]))
    u = u / np.linalg.norm(u)
    a, b = o - 22.0 * u, o + 66.0 * u
    ax.plot([a[0], b[0]], [a[1], b[1]], color=GREY, lw=1.1, ls="-.", zorder=1)
    centre, n = o + 44.0 * u, np.array([-u[1], u[0]])
    t = np.linspace(math.radians(30.0), math.radians(330.0), 60)
    ring = centre + np.outer(4.0 * np.cos(t), u) + np.outer(11.0 * np.sin(t), n)
    ax.plot(ring[:-2, 0], ring[:-2, 1], color=GREY, lw=1.5, zorder=2)
    arrow(ax, ring[-3], ring[-1], GREY, width=1.5, scale=12)
    label(ax, centre + 16.0 * n, "ω", GREY, size=17, ha="center")
    label(ax, b + np.array([2.0, 0.0]), "rotation\naxis", GREY, size=12, ha="left", va="bottom")

    # the body axes of this panel
    key_o = np.array([0.0, -128.0, -14.0])
    triad(ax, key_o, 20.0, ("x", "y", "z"), ("black",) * 3, width=1.6, size=13)
    label(ax, project(key_o) + np.array([6.0, -30.0]), "body axes", size=12, ha="center", va="top")

    # the key
    lines = [
        "r_i = r + d_i   (body axes, metres)",
        "r_i: accelerometer i's arm from O",
        "d_i: its arm from C (the IMU's own)",
        "r: the offset from O to C (the set-up's)",
        "r_x[y]: accelerometer x's arm, y component",
        "accelerometer i reads u_i · (f + ω̇ × r_i + ω × (ω × r_i)):",
        "the tangential term ω̇ × r_i, the centripetal ω × (ω × r_i)",
    ]
    ax.text(
        0.0,
        0.0,
        "\n".join(lines),
        transform=ax.transAxes,
        fontsize=12.5,
        ha="left",
        va="bottom",
        linespacing=1.3,
        bbox=dict(boxstyle="round,pad=0.45", fc="white", ec="#bbbbbb"),
        zorder=7,
    )

    ax.set_xlim(-150.0, 118.0)
    ax.set_ylim(-140.0, 122.0)
    ax.set_title("lever arms and the triad point (a sketch, not to scale)", fontsize=15, loc="left")


def draw(path: Path = OUT) -> Path:
    fig = Figure(figsize=(12.0, 7.4), layout="constrained")
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.0, 2.2]})
    for ax in (left, right):
        ax.set_aspect("equal")
        ax.axis("off")
    frames_panel(left)
    geometry_panel(right)
    fig.savefig(path, dpi=120, metadata={"Software": None})  # no version string: the same file every run
    return path


if __name__ == "__main__":
    print(f"wrote {draw()}")
