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

# The E-STOP at the top and at the bottom of the page (where a page rests): on screen, what a finger at
# its centre hits, and at least 8 px clear of every visible control (a control that ends beside it is an
# accidental press waiting to happen). A control scrolled out of its own box does not count.
ESTOP_CLEAR = """() => {
    const button = document.getElementById('estop-btn');
    if (!button) return ['no E-STOP button'];
    const selector = 'a[href], button, input:not([type=hidden]), select, textarea, summary, h1, h2, h3, '
        + '[role=slider], canvas';
    const gap = 8;
    const report = [];
    const name = (el) => `${el.tagName.toLowerCase()}${el.id ? '#' + el.id : ''}`
        + ` "${(el.textContent || el.value || el.getAttribute('aria-label') || '').trim().slice(0, 30)}"`;
    const visibleBox = (el) => {
        let r = el.getBoundingClientRect();
        let box = {left: r.left, top: r.top, right: r.right, bottom: r.bottom};
        for (let p = el.parentElement; p && p !== document.body; p = p.parentElement) {
            const cs = getComputedStyle(p);
            if (!/(auto|scroll|hidden|clip)/.test(cs.overflow + cs.overflowX + cs.overflowY)) continue;
            const c = p.getBoundingClientRect();
            box = {left: Math.max(box.left, c.left), top: Math.max(box.top, c.top),
                   right: Math.min(box.right, c.right), bottom: Math.min(box.bottom, c.bottom)};
        }
        return box;
    };
    for (const where of ['top', 'bottom']) {
        window.scrollTo(0, where === 'top' ? 0 : document.documentElement.scrollHeight);
        const r = button.getBoundingClientRect();
        if (r.left < 0 || r.top < 0 || r.right > innerWidth || r.bottom > innerHeight) {
            report.push(`at the ${where} the E-STOP is off the screen (${Math.round(r.left)}, ${Math.round(r.top)})`);
            continue;
        }
        const hit = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
        if (!hit || !button.contains(hit)) {
            report.push(`at the ${where} a tap on the E-STOP hits ${hit ? name(hit) : 'nothing'}`);
        }
        for (const el of document.querySelectorAll(selector)) {
            if (button.contains(el) || el.contains(button) || el.closest('[hidden], .estop-banner')) continue;
            const style = getComputedStyle(el);
            if (style.visibility === 'hidden' || style.display === 'none') continue;
            const c = visibleBox(el);
            if (c.right - c.left < 2 || c.bottom - c.top < 2) continue;
            // The part of the control within the gap around the button: is any of it what the eye sees there?
            const near = {left: Math.max(c.left, r.left - gap), top: Math.max(c.top, r.top - gap),
                          right: Math.min(c.right, r.right + gap), bottom: Math.min(c.bottom, r.bottom + gap)};
            if (near.right <= near.left || near.bottom <= near.top) continue;
            const seen = [[0.5, 0.5], [0.1, 0.1], [0.9, 0.1], [0.1, 0.9], [0.9, 0.9]].some(([fx, fy]) => {
                // What is there beneath the button itself: a control under it is covered by it.
                const at = document.elementsFromPoint(near.left + (near.right - near.left) * fx,
                                                      near.top + (near.bottom - near.top) * fy)
                    .find((hit) => !button.contains(hit));
                return at && (el.contains(at) || at.contains(el));
            });
            if (seen) report.push(`at the ${where} the E-STOP is on or beside ${name(el)}`);
        }
    }
    window.scrollTo(0, 0);
    return report;
}"""
