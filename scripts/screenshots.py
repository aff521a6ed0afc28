"""Screenshots of every page at a desktop (1366x800) and a phone (390x844) width, into docs/screenshots/.

Runs the whole product (simulator + server, tests/stack.py) and Debian's Chromium; run it
after a change to the pages:  .venv/bin/python scripts/screenshots.py
or of some pages at one width:  .venv/bin/python scripts/screenshots.py statemachine topics --width phone
"""

from __future__ import annotations

import argparse
import itertools
import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.browser.support import login  # noqa: E402
from tests.stack import Stack  # noqa: E402

OUT = ROOT / "docs" / "screenshots"
CHROMIUM = os.environ.get("CHROMIUM_PATH") or shutil.which("chromium") or "/usr/bin/chromium"
WIDTHS = {"desktop": {"width": 1366, "height": 800}, "phone": {"width": 390, "height": 844}}
THEMES = ("light", "dark")  # the browser's colour scheme; the pages follow it
# page name -> (path, what must be on screen before the picture is taken)
PAGES = {
    "dashboard": ("/", '[data-field="battery.percent"]:text-matches("%")'),
    "map": ("/map/", '#map-view[data-ready="1"]'),
    "drive": ("/drive/", '#camera[data-state="live"]'),
    "topics": ("/topics/", "#topics-rows tr"),
    "statemachine": ("/statemachine/", "#smach-graph svg"),
    "diagnostics": ("/diagnostics/", "#diagnostics-table tbody tr:not(.diag-empty)"),
    "history": ("/history/", "#plot-form"),
    "activity": ("/activity/", "#activity"),
    "admin": ("/admin/", "#content"),
    "api": ("/api/docs/", ".swagger-ui .opblock"),
}


def with_unlisted(page, pages: dict[str, tuple[str, str]]) -> dict[str, tuple[str, str]]:
    """``pages`` and every other page the navigation links to (named after its path, taken once
    its main part is there), so a page added to the site is never left out; say so, for the README."""
    linked = page.eval_on_selector_all(".mainnav a", "links => links.map(a => new URL(a.href).pathname)")
    listed = {path for path, _ in pages.values()}
    extra = {path.strip("/").replace("/", "-"): (path, "main") for path in linked if path not in listed}
    for name in extra:
        print(f"note: {extra[name][0]} is not listed in scripts/screenshots.py; shot as {name}-*.png", file=sys.stderr)
    return {**pages, **extra}


def main() -> None:
    from playwright.sync_api import sync_playwright

    parser = argparse.ArgumentParser(description="Screenshots of the pages into docs/screenshots/.")
    parser.add_argument("pages", nargs="*", help="page names (default: every page)")
    parser.add_argument("--width", choices=list(WIDTHS), action="append", help="default: every width")
    parser.add_argument("--theme", choices=THEMES, action="append",
                        help="default: both (the dark ones as NAME-WIDTH-dark.png)")
    args = parser.parse_args()
    unknown = set(args.pages) - set(PAGES)
    if unknown:
        parser.error(f"unknown pages {sorted(unknown)}; known: {', '.join(PAGES)}")

    OUT.mkdir(parents=True, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("DATABASE_URL", "REDIS_URL")}
    os.environ.clear()
    os.environ.update(env)
    with Stack() as stack, sync_playwright() as p:
        stack.wait_robot_online()
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--headless=new", "--no-sandbox", "--disable-gpu"])
        for (width_name, viewport), theme in itertools.product(WIDTHS.items(), THEMES):
            if (args.width and width_name not in args.width) or (args.theme and theme not in args.theme):
                continue
            phone = width_name == "phone"
            context = browser.new_context(viewport=viewport, is_mobile=phone, has_touch=phone, device_scale_factor=1,
                                          color_scheme=theme)
            page = context.new_page()
            login(page, stack, "ada")
            pages = {n: PAGES[n] for n in args.pages} if args.pages else with_unlisted(page, PAGES)
            for name, (path, ready) in pages.items():
                page.goto(f"{stack.url}{path}")
                page.wait_for_selector(ready, timeout=20_000)
                page.wait_for_timeout(1500)  # let live values arrive
                target = OUT / f"{name}-{width_name}{'-dark' if theme == 'dark' else ''}.png"
                page.screenshot(path=str(target), full_page=False)
                print(target.relative_to(ROOT))
            context.close()
        browser.close()


if __name__ == "__main__":
    main()
