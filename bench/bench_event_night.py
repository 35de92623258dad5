#!/usr/bin/env python3
"""An event night on `drboard serve`, measured in Chromium: push to row visible on the big screen.

Not a test: it starts `drboard serve --host 0.0.0.0` on a board of its own, seeds 30 racers,
then acts as racers would on their own laptops: each racer (a HOME of their own) runs the join
command `serve` printed, verbatim, against the network address it printed (not localhost), and
pushes. A 1080p big screen, opened in Chromium at the address `serve` printed, records when each
arrival's row is first in view. It prints the push-to-visible latency (p50, p95), whether every
arrival was seen in view, whether the join code is on the screen, and each page's width on a
390 px phone; with --screenshots DIR it saves the screenshots the README uses.

    python bench/bench_event_night.py                    # 14 pushes, 3 s apart
    python bench/bench_event_night.py --pushes 20 --gap 2
    python bench/bench_event_night.py --screenshots docs/screenshots

Needs Playwright and a Chromium (`apt install chromium`, or DRBOARD_CHROMIUM=/path).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from figures import Report, p50_p95  # noqa: E402

from tests.recordkit import make_record  # noqa: E402

BOARD = "reInvent2019_track"
DRBOARD = [sys.executable, "-m", "drboard_cli"]
#: Records when each row (racer and submission) is first wholly in view, by the page's clock.
WATCH_ROWS = """
window.seenRows = {};
(function look() {
  for (const row of document.querySelectorAll("tr[data-racer]")) {
    const key = row.dataset.racer + "|" + row.dataset.submission;
    if (key in window.seenRows) continue;
    const box = row.getBoundingClientRect();
    if (box.top >= 0 && box.bottom <= innerHeight) window.seenRows[key] = Date.now();
  }
  requestAnimationFrame(look);
})();
"""


def environment(home: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DRBOARD_", "XDG_"))}
    return env | {"HOME": str(home), "XDG_DATA_HOME": str(home / "data"),
                  "XDG_CONFIG_HOME": str(home / "config"), "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}


class Serve:
    """`drboard serve` in its own process, and what it printed."""

    def __init__(self, folder: Path) -> None:
        self.env = environment(folder / "organiser")
        self.process = subprocess.Popen(
            [*DRBOARD, "--db", str(folder / "night.db"), "serve", "--host", "0.0.0.0", "--port", "0",
             "--board", BOARD], env=self.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True)
        assert self.process.stdout is not None
        self.lines: list[str] = []
        while not any("drboard join" in line for line in self.lines):
            line = self.process.stdout.readline()
            if not line:
                said = self.process.stderr.read() if self.process.stderr else ""
                raise SystemExit(f"drboard serve stopped: {said}")
            self.lines.append(line.rstrip())
        self.url = re.search(r"on (http://\S+)", self.lines[0])[1]  # type: ignore[index]
        self.screen = next(line.split()[-1] for line in self.lines if "Big screen:" in line)
        self.join = re.search(r"(drboard join \S+ --endpoint \S+)", next(
            line for line in self.lines if "drboard join" in line))[1]  # type: ignore[index]
        self.code = self.join.split()[2]
        self.local = re.sub(r"//[^:/]+", "//127.0.0.1", self.url)
        self.log: list[str] = []
        threading.Thread(target=self._read_log, daemon=True).start()

    def _read_log(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.log.append(line.rstrip())

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=30)


def post(url: str, record: Any, token: str | None = None) -> int:
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    request = urllib.request.Request(f"{url}/boards/{BOARD}/submissions", method="POST",
                                     data=record.model_dump_json().encode(), headers=headers)
    with urllib.request.urlopen(request, timeout=30) as answer:
        return int(answer.status)


def join_as_a_racer(serve: Serve, home: Path) -> str:
    """Run the printed join command verbatim, as a racer with a HOME of their own; the token."""
    words = shlex.split(serve.join)
    assert words[0] == "drboard"
    result = subprocess.run([*DRBOARD, *words[1:]], env=environment(home), capture_output=True,
                            text=True, timeout=60)
    if result.returncode != 0:
        raise SystemExit(f"the printed join command failed: {serve.join}\n{result.stderr}")
    saved = json.loads((home / "config" / "drboard" / "tokens.json").read_text())
    return str(saved[serve.url]["access_token"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pushes", type=int, default=14)
    parser.add_argument("--gap", type=float, default=3.0, help="seconds between two pushes")
    parser.add_argument("--seed-racers", type=int, default=30)
    parser.add_argument("--screenshots", type=Path)
    parser.add_argument("--json", type=Path)
    options = parser.parse_args()
    from playwright.sync_api import sync_playwright

    chromium = os.environ.get("DRBOARD_CHROMIUM") or shutil.which("chromium") or shutil.which(
        "chromium-browser")
    if not chromium:
        raise SystemExit("no Chromium: apt install chromium (or DRBOARD_CHROMIUM=/path)")
    report = Report(config={"pushes": options.pushes, "gap_s": options.gap,
                            "seed_racers": options.seed_racers})
    with tempfile.TemporaryDirectory(prefix="drboard-night-") as temporary:
        folder = Path(temporary)
        serve = Serve(folder)
        try:
            run(serve, folder, options, report, chromium, sync_playwright)
        finally:
            serve.stop()
        print("\nThe serve log (last lines):", *serve.log[-6:], sep="\n  ")
    report.print_summary("drboard serve: an event night in Chromium", options.json)


def run(serve: Serve, folder: Path, options: Any, report: Report, chromium: str,
        sync_playwright: Any) -> None:
    network = not serve.url.startswith(("http://127.", "http://localhost"))
    report.add("join command printed with the network address", 1 if network else 0, "",
               ok=network, note=serve.join)
    for n in range(options.seed_racers):  # the organiser, at the serving laptop
        post(serve.local, make_record(f"Racer {n:02d}", [(9_500 + 61 * n, 100), (10_400, 100)],
                                      model=f"seed-{n}"))
    tokens = {}
    for n in range(options.pushes):
        tokens[f"Joiner {n:02d}"] = join_as_a_racer(serve, folder / f"racer-{n:02d}")
    report.add("racers joined with the printed command, verbatim", len(tokens), "",
               ok=len(tokens) == options.pushes, target=f"{options.pushes}")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1920, "height": 1080})
        page.goto(serve.screen)
        page.wait_for_selector("tr[data-racer]")
        page.evaluate(WATCH_ROWS)
        code_shown = page.locator("p.join strong").inner_text().strip()
        code_px = page.eval_on_selector("p.join strong", "e => parseFloat(getComputedStyle(e).fontSize)")
        report.add("join code on the big screen (font size)", code_px, "px", ok=code_shown == serve.code
                   and code_px >= 30, target=">= 30 px, the printed code")
        in_view = page.eval_on_selector_all("tr[data-racer]", """rows => rows.filter((row) => {
            const box = row.getBoundingClientRect(); return box.top >= 0 && box.bottom <= innerHeight;
        }).length""")
        report.add("rows in view at 1080p", in_view, "", ok=in_view >= 15, target=">= 15")
        if options.screenshots:
            options.screenshots.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(options.screenshots / "big-screen-1080p-30-racers.png"))
        pushed: dict[str, tuple[float, str]] = {}
        leader_shot = False
        for index, (racer, token) in enumerate(tokens.items()):
            # new racers at every depth of the board; every fifth takes the lead
            best = 8_000 - 10 * index if index % 5 == 4 else 9_480 + 150 * index
            record = make_record(racer, [(best, 100), (best + 400, 100)], model=f"night-{index}")
            started = time.time()
            post(serve.url, record, token)
            pushed[f"{racer}|{record.submission_id}"] = (started, racer)
            if index % 5 == 4 and options.screenshots and not leader_shot:
                page.wait_for_selector("#leader-banner:not([hidden])", timeout=5000)
                page.screenshot(path=str(options.screenshots / "big-screen-new-leader.png"))
                leader_shot = True
            time.sleep(options.gap)
        page.wait_for_timeout(8000)
        seen = page.evaluate("window.seenRows")
        latencies = [seen[key] / 1000 - started for key, (started, _) in pushed.items() if key in seen]
        missed = [racer for key, (_, racer) in pushed.items() if key not in seen]
        p50, p95 = p50_p95(latencies) if latencies else (None, None)
        report.add("push to row visible on the big screen, p50", p50, "s")
        report.add("push to row visible on the big screen, p95", p95, "s", limit=3.0)
        report.add("arrivals seen in view", len(latencies), "", ok=not missed,
                   target=f"all {len(pushed)}", note=f"missed: {missed}" if missed else "")
        if options.screenshots:
            big = browser.new_page(viewport={"width": 3840, "height": 2160})
            big.goto(serve.screen)
            big.wait_for_selector("tr[data-racer]")
            big.screenshot(path=str(options.screenshots / "big-screen-4k.png"))
            big.close()
        phone = browser.new_page(viewport={"width": 390, "height": 844})
        for name, path in (("board", f"/boards/{BOARD}/view"),
                           ("racer", f"/boards/{BOARD}/racers/Joiner%2004/view"),
                           ("compare", f"/boards/{BOARD}/compare/view?racer=Joiner%2009&racer=Racer%2000"),
                           ("insights", f"/boards/{BOARD}/insights/view")):
            phone.goto(serve.url + path)
            phone.wait_for_timeout(300)
            width = phone.evaluate("document.documentElement.scrollWidth")
            report.add(f"{name} page width on a 390 px phone", width, "px", limit=390, target="<= 390 px")
            if options.screenshots:
                phone.screenshot(path=str(options.screenshots / f"phone-{name}.png"))
        browser.close()


if __name__ == "__main__":
    main()
