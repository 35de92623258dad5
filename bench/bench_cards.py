"""How fast the result cards are drawn: building a racer's card as SVG (its text fitted with the
font's widths) and drawing its PNG with resvg, on this machine, warm (the fonts' widths and
resvg already loaded), and the first PNG a process draws (cold: resvg imported, the fonts read).
A script that prints figures, not a test.

    python bench/bench_cards.py [--reps N] [--json FILE]
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from figures import Report, p50_p95, timed_ms

#: The PNG of a card must be drawn well inside a link preview's patience (a few seconds) and
#: the function's timeout: a generous bound on this machine.
RENDER_TARGET_MS = 200
LONG = "Maximilian the Unstoppable Racer of the Northern Leagues and Beyond"
COLD = """
import time
from drboard_functions.cards import RacerCard, racer_svg
start = time.perf_counter()
from drboard_functions.cards.png import render
svg = racer_svg(RacerCard(board_title="Club night", subtitle="best lap", rank=2, field=30,
                          racer="Ada", model_name="ada-v7", result="9.120 s", result_label="best lap",
                          gap="+0.465 s to the leader", leads=False, date="2026-12-01"))
render(svg)
print((time.perf_counter() - start) * 1000)
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reps", type=int, default=50, help="repetitions of each warm figure")
    parser.add_argument("--json", type=Path, help="also save the figures here")
    args = parser.parse_args(argv)

    from drboard_functions.cards import Podium, PodiumPlace, RacerCard, podium_svg, racer_svg
    from drboard_functions.cards.png import render

    card = RacerCard(board_title="Club night — December", subtitle="Smile Speedway · best lap",
                     rank=2, field=30, racer=LONG, model_name="ada-ppo-v7-final", result="9.120 s",
                     result_label="best lap", gap="+0.465 s to the leader", leads=False,
                     date="2026-12-01")
    podium = Podium(title="Club season 2026", subtitle="Season podium · after 4 of 6 rounds",
                    date="2026-12-01", places=[PodiumPlace(n, name, f"{points} pts", "2 wins", gap)
                                               for n, name, points, gap in [(1, "Blaze", 125, ""),
                                                                            (2, LONG, 107, "−18 pts"),
                                                                            (3, "Indy", 88, "−37 pts")]])
    report = Report()
    svg = racer_svg(card)
    render(svg)  # warm: resvg loaded, the fonts' widths read
    build = [timed_ms(lambda: racer_svg(card)) for _ in range(args.reps)]
    draw = [timed_ms(lambda: render(svg)) for _ in range(args.reps)]
    podium_svg_text = podium_svg(podium)
    draw_podium = [timed_ms(lambda: render(podium_svg_text)) for _ in range(args.reps)]
    p50, p95 = p50_p95(build)
    report.add("racer card as SVG (a long name fitted) p50", p50, "ms", note=f"p95 {p95:.2f} ms")
    p50, p95 = p50_p95(draw)
    report.add("racer card's PNG drawn from its SVG p50", p50, "ms", limit=RENDER_TARGET_MS,
               note=f"p95 {p95:.1f} ms; resvg with the two card fonts")
    p50, p95 = p50_p95(draw_podium)
    report.add("podium card's PNG p50", p50, "ms", limit=RENDER_TARGET_MS, note=f"p95 {p95:.1f} ms")
    report.add("racer card's PNG size", len(render(svg)) / 1000, "KB")
    cold = [float(subprocess.run([sys.executable, "-c", COLD], capture_output=True, text=True,
                                 check=True, env=os.environ).stdout) for _ in range(5)]
    p50, _ = p50_p95(cold)
    report.add("first PNG of a process (resvg imported, fonts read) p50", p50, "ms",
               note="5 fresh processes")
    report.print_summary(f"drboard result cards · Python {platform.python_version()} · "
                         f"{platform.machine()} · {os.cpu_count()} CPUs", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
