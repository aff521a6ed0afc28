"""Layout checks run inside the page: horizontal overflow, controls covered by other elements."""

from __future__ import annotations

# For every visible control and card heading: scroll it to the middle of the screen and ask the
# browser what is on top at its centre and at four points halfway to its corners. Anything that is
# not the control itself (or inside it, or its own label) is reported as covering it.
COVERED_CONTROLS = """() => {
    const selector = 'a[href], button, input:not([type=hidden]), select, textarea, summary, .card h2, #estop-btn';
    const report = [];
    const name = (el) => el ? `${el.tagName.toLowerCase()}${el.id ? '#' + el.id : ''}`
        + `${el.className && typeof el.className === 'string' ? '.' + el.className.trim().split(/\\s+/).join('.') : ''}`
        + ` "${(el.textContent || el.value || el.getAttribute('aria-label') || '').trim().slice(0, 30)}"` : 'nothing';
    for (const el of document.querySelectorAll(selector)) {
        const style = getComputedStyle(el);
        if (style.visibility === 'hidden' || el.closest('[hidden]')) continue;
        let r = el.getBoundingClientRect();
        if (r.width < 2 || r.height < 2) continue;
        el.scrollIntoView({ block: 'center', inline: 'nearest' });
        r = el.getBoundingClientRect();
        // The centre and four points halfway to the corners (inside a round button too).
        const points = [[0.5, 0.5], [0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]
            .map(([fx, fy]) => [r.left + r.width * fx, r.top + r.height * fy]);
        for (const [x, y] of points) {
            if (x < 0 || y < 0 || x >= innerWidth || y >= innerHeight) continue;
            // Content clipped by its own scrolling box (a table, the log) is not covered.
            const hit = document.elementFromPoint(x, y);
            // The control itself, something inside it, or a box around it (a rounded corner).
            if (!hit || el.contains(hit) || hit.contains(el)) continue;
            let clipper = el.parentElement, clipped = false;
            while (clipper && clipper !== document.body) {
                const cs = getComputedStyle(clipper);
                if (/(auto|scroll|hidden)/.test(cs.overflow + cs.overflowX + cs.overflowY)) {
                    const c = clipper.getBoundingClientRect();
                    if (x < c.left || x > c.right || y < c.top || y > c.bottom) { clipped = true; break; }
                }
                clipper = clipper.parentElement;
            }
            if (clipped) continue;
            report.push(`${name(el)} is covered by ${name(hit)} at (${Math.round(x)}, ${Math.round(y)})`);
            break;
        }
    }
    window.scrollTo(0, 0);
    return report;
}"""

HORIZONTAL_OVERFLOW = "() => document.documentElement.scrollWidth - document.documentElement.clientWidth"
