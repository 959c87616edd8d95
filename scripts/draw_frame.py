"""Draw the coordinate frame of magcilia (writes docs/frame.png): side view (x–z) and top view."""

from __future__ import annotations

import argparse
import math

import numpy as np

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.report.figures import new_figure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="docs/frame.png")
    args = parser.parse_args()
    from matplotlib.patches import Circle, Rectangle

    s = mc.Setup.paper()
    depth = s.sensor.depth * 1e3
    x_f, y_f, z_f = (c * 1e3 for c in s.position)
    h, rb = s.cilium.height * 1e3, s.cilium.base_radius * 1e3
    theta = math.radians(30.0)
    fig, axes = new_figure(ncols=2, size=(5.2, 4.6))
    ax = axes[0, 0]
    # sensor case (top at z = depth) and element at the origin
    ax.add_patch(Rectangle((-1.5, -depth), 4.5, 2 * depth, color="0.85", zorder=0))
    ax.plot(0, 0, "s", color="tab:red", ms=8)
    ax.annotate("sensing element (origin)\nsensitive axis +x", (0, 0), (0.25, -0.55),
                color="tab:red", fontsize=8)
    ax.annotate("", (1.0, 0), (0, 0), arrowprops={"arrowstyle": "->", "color": "tab:red", "lw": 2})
    ax.axhline(depth, color="0.4", lw=0.8)
    ax.text(-1.45, depth + 0.05, f"case top, z = depth = {depth:.2f} mm", fontsize=8)
    # cilium: upright (dashed) and tilted by theta about y through the base centre
    base = np.array([x_f, depth + z_f])
    for th, style in ((0.0, "--"), (theta, "-")):
        axis = np.array([math.sin(th), math.cos(th)])
        normal = np.array([math.cos(th), -math.sin(th)])
        poly = np.array([base + rb * normal, base + h * axis, base - rb * normal])
        ax.fill(poly[:, 0], poly[:, 1], alpha=0.5 if th else 0.15, color="tab:blue", ls=style,
                ec="tab:blue")
    ax.plot(*base, "k.", ms=6)
    ax.annotate("base centre\n(x_f, y_f, depth + z_f)", base, (base[0] + 0.3, base[1] - 0.45),
                fontsize=8)
    arc = np.linspace(0, theta, 20)
    ax.plot(base[0] + 1.6 * np.sin(arc), base[1] + 1.6 * np.cos(arc), "k", lw=0.8)
    ax.text(base[0] + 0.35, base[1] + 1.75, "θ > 0: tip toward +x", fontsize=8)
    ax.annotate("", (0, 1.2), (0, 0), arrowprops={"arrowstyle": "->"})
    ax.text(-0.25, 1.1, "+z", fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlim(-1.5, 3.5)
    ax.set_ylim(-0.9, 4.6)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title("side view (x–z plane), paper placement")
    ax2 = axes[0, 1]
    ax2.plot(0, 0, "s", color="tab:red", ms=8)
    ax2.annotate("", (1.0, 0), (0, 0), arrowprops={"arrowstyle": "->", "color": "tab:red", "lw": 2})
    ax2.add_patch(Circle((x_f, y_f), rb, color="tab:blue", alpha=0.6))
    ax2.annotate("", (x_f + 0.8, y_f), (x_f, y_f), arrowprops={"arrowstyle": "->"})
    ax2.text(x_f + 0.1, y_f + 0.25, "tilt direction (+x)", fontsize=8)
    ax2.text(x_f - 0.9, y_f - 0.5, f"base at ({x_f:.2f}, {y_f:.2f}) mm", fontsize=8)
    ax2.set_aspect("equal")
    ax2.set_xlim(-1.0, 3.5)
    ax2.set_ylim(-1.0, 3.0)
    ax2.set_xlabel("x (mm)")
    ax2.set_ylabel("y (mm)")
    ax2.set_title("top view")
    for a in (ax, ax2):
        a.grid(alpha=0.3)
    save_figure(fig, args.out, dpi=120)


if __name__ == "__main__":
    main()
