"""The robot's SMACH state machine as a graph: containers from ``container_structure``, the
active states from ``container_status`` (or, without introspection, from ``state_change``).

Plain functions on plain data. Node paths are SMACH's own (``/SM_ROOT/behaviour/idle``); a
container's outcome is the node ``<container path>:<outcome>``. The DOT text is what the
state machine page lays out (Graphviz, in the browser); nodes and edges carry ids the page
looks up in the ``nodes`` and ``edges`` tables to highlight states and send events.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

# Graphviz sizes labels by its own font tables, not the browser's fonts. Monospace text is 0.6 em
# a character in Courier and in every browser's monospace font, bold or not, so the room laid out
# for a label is the room it takes on the page; a proportional font overflows it and labels overlap.
FONT = '"Courier"'

# (from child, outcome, to): the child's outcome leads to a sibling or to a container outcome.
Edge = tuple[str, str, str]


@dataclass(frozen=True)
class Container:
    path: str
    children: tuple[str, ...]
    edges: tuple[Edge, ...]
    outcomes: tuple[str, ...]

    @property
    def name(self) -> str:
        return self.path.rsplit("/", 1)[-1]


def container_from_message(msg: Mapping[str, Any]) -> Container:
    """A ``SmachContainerStructure`` message; ValueError when it does not describe a container."""
    path = msg.get("path")
    if not isinstance(path, str) or not path.startswith("/"):
        raise ValueError(f"container path {path!r} is not an absolute path")
    lists = {}
    for name in ("children", "internal_outcomes", "outcomes_from", "outcomes_to", "container_outcomes"):
        value = msg.get(name) or []
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ValueError(f"{path}: {name} is not a list of names")
        lists[name] = value
    froms, outcomes, tos = lists["outcomes_from"], lists["internal_outcomes"], lists["outcomes_to"]
    if not len(froms) == len(outcomes) == len(tos):
        raise ValueError(f"{path}: outcomes_from, internal_outcomes and outcomes_to differ in length")
    return Container(path, tuple(lists["children"]), tuple(zip(froms, outcomes, tos, strict=True)),
                     tuple(lists["container_outcomes"]))


def parent_of(path: str) -> str:
    return path.rsplit("/", 1)[0]


def outcome_node(container: str, outcome: str) -> str:
    return f"{container}:{outcome}"


def roots(containers: Mapping[str, Container]) -> list[str]:
    """Containers no other known container holds, in path order."""
    return sorted(p for p in containers if parent_of(p) not in containers)


def first_state(containers: Mapping[str, Container], path: str) -> str:
    """The node an edge into container ``path`` points at (its first child, recursively)."""
    c = containers[path]
    if not c.children:
        return outcome_node(path, c.outcomes[0]) if c.outcomes else path
    child = f"{path}/{c.children[0]}"
    return first_state(containers, child) if child in containers else child


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", " ") + '"'


def graph_view(containers: Mapping[str, Container]) -> dict[str, Any]:
    """Everything the page needs to draw the machine: DOT text, node and edge tables, a version."""
    node_ids: dict[str, str] = {}
    clusters = {p: f"cluster_{i}" for i, p in enumerate(sorted(containers))}
    nodes: list[dict[str, Any]] = []
    edges: list[dict[str, Any]] = []
    # Left to right: the many sibling states stack down the page rather than across it, a shape
    # that scrolls less inside a phone's card and shrinks less when fitted to a desktop's.
    lines = ["digraph smach {", f"compound=true; rankdir=LR; nodesep=0.4; ranksep=0.6; fontname={FONT};",
             f'node [shape=box, style="rounded,filled", fillcolor="#ffffff", fontname={FONT}, fontsize=12];',
             f"edge [fontname={FONT}, fontsize=11, arrowsize=0.7];"]
    # With one root its children are the top level; several roots are each a box of their own.
    top = roots(containers)
    flat = top[0] if len(top) == 1 else None

    def add_node(path: str, name: str, kind: str, container: str, indent: str) -> None:
        node_id = node_ids.setdefault(path, f"n{len(node_ids)}")
        nodes.append({"id": node_id, "path": path, "name": name, "kind": kind, "container": container})
        shape = ' shape=ellipse, style="filled", fillcolor="#eef1f4", fontsize=9,' if kind == "outcome" else ""
        lines.append(f"{indent}{node_id} [id={_quote(node_id)},{shape} label={_quote(name)}];")

    def add_container(path: str, depth: int) -> None:
        c = containers[path]
        indent = "  " * depth
        boxed = path != flat
        if boxed:
            lines.append(f'{indent}subgraph {clusters[path]} {{ id={_quote(clusters[path])}; '
                         f'label={_quote(c.name)}; style="rounded"; color="#8a96a3";')
        for child in c.children:
            child_path = f"{path}/{child}"
            if child_path in containers:
                add_container(child_path, depth + 1)
            else:
                add_node(child_path, child, "state", path, indent + "  ")
        for outcome in c.outcomes:
            add_node(outcome_node(path, outcome), outcome, "outcome", path, indent + "  ")
        if boxed:
            lines.append(f"{indent}}}")

    for root in top:
        add_container(root, 0)
    for path in sorted(containers):
        c = containers[path]
        for child, outcome, target in c.edges:
            tail_path, head_path = f"{path}/{child}", _target(containers, c, target)
            attrs = [f"label={_quote(outcome)}"]
            tail, head = tail_path, head_path
            if tail_path in containers:
                if outcome in containers[tail_path].outcomes:
                    tail = outcome_node(tail_path, outcome)
                else:
                    tail = first_state(containers, tail_path)
                    attrs.append(f"ltail={clusters[tail_path]}")
            if head_path in containers:
                head = first_state(containers, head_path)
                attrs.append(f"lhead={clusters[head_path]}")
            for end in (tail, head):
                if end not in node_ids:  # named by an edge only (the robot left it out of children)
                    add_node(end, end.rsplit("/", 1)[-1], "state", parent_of(end), "")
            edge_id = f"e{len(edges)}"
            edges.append({"id": edge_id, "container": path, "from": tail_path, "event": outcome, "to": head_path})
            lines.append(f"{node_ids[tail]} -> {node_ids[head]} [id={_quote(edge_id)}, {', '.join(attrs)}];")
    lines.append("}")
    dot = "\n".join(lines)
    described = json.dumps([[c.path, c.children, c.edges, c.outcomes] for _, c in sorted(containers.items())])
    return {
        "version": hashlib.sha1(described.encode()).hexdigest()[:12],
        "containers": sorted(containers),
        "nodes": nodes,
        "edges": edges,
        "clusters": {clusters[p]: p for p in sorted(containers)},
        "dot": dot,
    }


def _target(containers: Mapping[str, Container], c: Container, target: str) -> str:
    """Where an edge of container ``c`` ends: a sibling state, or one of ``c``'s outcomes."""
    if target in c.children or target not in c.outcomes:
        return f"{c.path}/{target}"
    return outcome_node(c.path, target)


# --- active states ------------------------------------------------------------------------

@dataclass(frozen=True)
class Status:
    active: tuple[str, ...]
    initial: tuple[str, ...]
    t: float


def status_from_message(msg: Mapping[str, Any], t: float) -> tuple[str, Status]:
    path = msg.get("path")
    active, initial = msg.get("active_states") or [], msg.get("initial_states") or []
    if not isinstance(path, str) or not path.startswith("/"):
        raise ValueError(f"container path {path!r} is not an absolute path")
    if not all(isinstance(s, str) for s in [*active, *initial]):
        raise ValueError(f"{path}: states are not names")
    return path, Status(tuple(active), tuple(initial), t)


def active_from_status(containers: Mapping[str, Container], statuses: Mapping[str, Status]) -> list[str]:
    """Active node paths, walking down from the roots: a container's own report counts only
    while its parent has it active (a container left behind keeps its last report)."""
    active: list[str] = []
    pending = [p for p in statuses if parent_of(p) not in statuses and parent_of(p) not in containers]
    while pending:
        path = pending.pop(0)
        for state in statuses[path].active:
            node = f"{path}/{state}"
            active.append(node)
            if node in statuses:
                pending.append(node)
    return active


def active_from_state_change(containers: Mapping[str, Container], state: str) -> list[str]:
    """Without introspection: the state ``state_change`` names, and the containers holding it."""
    if not state:
        return []
    for path in sorted(containers):
        if state in containers[path].children:
            chain = [f"{path}/{state}"]
            while path in containers and parent_of(path) in containers:
                chain.insert(0, path)
                path = parent_of(path)
            return chain
    return []


def leaves(active: Iterable[str]) -> list[str]:
    """The deepest active states: those that contain no other active state."""
    nodes = list(active)
    return [n for n in nodes if not any(other.startswith(n + "/") for other in nodes)]


def transitions_from(containers: Mapping[str, Container], nodes: Iterable[str]) -> list[dict[str, str]]:
    """The outcome edges leaving ``nodes``: each one an event an operator may send."""
    out = []
    for node in nodes:
        c = containers.get(parent_of(node))
        if c is None:
            continue
        child = node.rsplit("/", 1)[-1]
        out += [{"from": node, "event": outcome, "to": _target(containers, c, target)}
                for frm, outcome, target in c.edges if frm == child]
    return out


def active_view(containers: Mapping[str, Container], statuses: Mapping[str, Status], state_change: str,
                *, now: float, fresh_s: float) -> dict[str, Any]:
    """Which states are active and from where: introspection while it reports, else ``state_change``."""
    fresh = {p: s for p, s in statuses.items() if now - s.t <= fresh_s}
    if fresh:
        active, source = active_from_status(containers, fresh), "introspection"
    else:
        active, source = active_from_state_change(containers, state_change), "state_change" if state_change else ""
    deepest = leaves(active)
    return {"source": source, "active": active, "leaves": deepest,
            "transitions": transitions_from(containers, deepest)}
