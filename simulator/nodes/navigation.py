"""amcl, map_server, move_base and cyborg_navigation: localisation, the map, planning and named places.

move_base's local planner is simplified: it follows an A* path with a pure-pursuit controller.
"""

from __future__ import annotations

import itertools
import math
import random
import time
from collections.abc import Callable
from typing import Any

from robot import interface as ri

from .. import messages, world
from ..actions import ABORTED, ACTIVE, PREEMPTED, SUCCEEDED, ActionServer, Goal, Ros2Action
from ..bus import Bus, SimNode
from ..world import body_pose, grid, pose, wrap

NAV_NODE = "/cyborg_navigation"
MAX_W = 1.2
LOOKAHEAD_M = 0.4
XY_TOLERANCE_M = 0.15
YAW_TOLERANCE = 0.12
PATIENCE_S = 10.0  # no progress for this long: give up (move_base's controller patience)


class NavigationNode(SimNode):
    names = ("/amcl", "/map_server", "/move_base", "/cyborg_navigation")
    publishes = ("map", "amcl_pose", "plan", "current_location")

    def __init__(self, body: world.Base, world_map: world.WorldMap, rng: random.Random, nav_speed: float,
                 ros: int = ri.ROS1) -> None:
        self.body = body
        self.world = world_map
        self.rng = rng
        self.planner = world.Planner(world_map)
        self.max_v = nav_speed
        self.path: list[tuple[float, float]] = []  # the path under way, followed by pure pursuit
        self.goal_yaw = 0.0
        self.idx = 0
        self.active = False
        self._best = math.inf
        self._best_t = 0.0
        self.current_location = ""
        self._map_load_time = messages.stamp()
        mb, nav = ri.action("move_base", ros), ri.action("navigation", ros)

        if ros == ri.ROS1:
            self.move_base = ActionServer(mb.name, mb.type, self._move_base_goal, self._move_base_cancel)
            self.navigation = ActionServer(nav.name, nav.type, self._navigation_goal, self._navigation_cancel)
        else:  # Nav2's NavigateToPose (goal {pose, behavior_tree}) and the navigation orders, as action ops
            self.move_base = Ros2Action(mb.name, mb.type, self._move_base_goal, self._move_base_cancel,
                                        lambda g: {"target_pose": g["pose"]}, self._nav2_feedback)
            self.navigation = Ros2Action(nav.name, nav.type, self._navigation_goal, self._navigation_cancel)

    def start(self, bus: Bus) -> None:
        super().start(bus)
        self.move_base.install(bus)
        self.navigation.install(bus)
        bus.on("initialpose", self._initialpose)
        bus.on("move_base_simple_goal", self._simple_goal)
        bus.latch_lazily("map", self._map_message)
        bus.each_tick(self._step)
        bus.every(0.5, self._pub_amcl, wanted="amcl_pose")
        bus.every(0.2, self._pub_action_status)
        bus.every(1.0, self._pub_plan)
        bus.every(0.2, self._nav_feedback)
        bus.every(1.0, self._pub_location)

    # --- goals -------------------------------------------------------------------------

    def navigate(self, x: float, y: float, yaw: float, done: Callable[[int], None] | None = None) -> Goal:
        """An internal move_base goal (the navigation node is a move_base client)."""
        target = {"header": messages.header(ri.MAP_FRAME), "pose": pose(x, y, yaw)}
        goal = self.move_base.receive_goal({"goal_id": {"stamp": messages.stamp(),
                                                        "id": self.move_base.new_goal_id()},
                                            "goal": {"target_pose": target}})
        if goal.status == ACTIVE:
            goal.data["done"] = done
        elif done is not None:
            done(goal.status)
        return goal

    def cancel(self, goal: Goal) -> None:
        self.move_base.receive_cancel({"id": goal.id, "stamp": {"secs": 0, "nsecs": 0}})

    def random_free_point(self) -> tuple[float, float]:
        w, p = self.world, self.planner
        for _ in range(200):
            x = w.origin_x + self.rng.uniform(0, w.width * w.resolution)
            y = w.origin_y + self.rng.uniform(0, w.height * w.resolution)
            r, c = p.to_cell(x, y)
            if 0 <= r < p.h and 0 <= c < p.w and p.cost[r, c] == 1:
                return x, y
        return self.body.x, self.body.y

    def _initialpose(self, m: dict[str, Any]) -> None:
        p = m["pose"]["pose"]
        yaw = world.quaternion_to_yaw(p["orientation"])
        self.body.teleport(p["position"]["x"], p["position"]["y"], yaw)
        self.bus.rosout(2, "/amcl", f"Setting pose ({time.time():.6f}): {p['position']['x']:.3f} "
                                    f"{p['position']['y']:.3f} {yaw:.3f}")
        goal = self.move_base.current
        if goal is not None and self.active:
            self._move_base_goal(goal)  # replan from the new pose

    def _simple_goal(self, m: dict[str, Any]) -> None:
        self.move_base.receive_goal({"goal_id": {"stamp": {"secs": 0, "nsecs": 0}, "id": ""},
                                     "goal": {"target_pose": m}})

    def _move_base_goal(self, goal: Goal) -> None:
        goal.data["t0"] = self.bus.clock.now()
        target = goal.goal["target_pose"]["pose"]
        x, y = target["position"]["x"], target["position"]["y"]
        yaw = world.quaternion_to_yaw(target["orientation"])
        t0 = time.perf_counter()
        path = self.planner.plan((self.body.x, self.body.y), (x, y))
        if path is None:
            self.bus.rosout(8, "/move_base", "Failed to get a plan.")
            self._finish_move_base(goal, ABORTED, "Failed to find a valid plan. Even after executing recovery "
                                                  "behaviors.")
            return
        self.bus.rosout(2, "/move_base",
                        f"Got new plan ({len(path)} poses, {1000 * (time.perf_counter() - t0):.0f} ms)")
        self._follow(path, yaw, self.bus.clock.now())
        self._pub_plan(force=True)

    def _move_base_cancel(self, goal: Goal) -> None:
        self._halt(self.bus.clock.now())
        self._pub_plan(force=True)
        self._finish_move_base(goal)

    def _finish_move_base(self, goal: Goal, status: int | None = None, text: str = "") -> None:
        """End a move_base goal (already ended if cancelled) and tell ``navigate``'s ``done`` how it ended."""
        if status is not None:
            self.move_base.finish(goal, status, text)
        done = goal.data.pop("done", None)
        if done is not None:
            done(goal.status)

    def _navigation_goal(self, goal: Goal) -> None:
        order, name = goal.goal["order"], goal.goal["location_name"]
        if order == "navigation_go_to":
            loc = self.world.locations.get(name)
            if loc is None:
                self.bus.rosout(4, NAV_NODE, f"Unknown location '{name}'")
                self.navigation.finish(goal, ABORTED, f"unknown location {name}", {"status": "aborted"})
                return
            target = (loc.x, loc.y, loc.yaw)
        elif order == "navigation_dock":
            loc = self.world.locations["charging_station"]
            name, target = loc.name, (loc.x, loc.y, loc.yaw)
        elif order == "navigation_wander":
            x, y = self.random_free_point()
            name, target = "", (x, y, 0.0)
        else:
            self.bus.rosout(4, NAV_NODE, f"Unknown navigation order '{order}'")
            self.navigation.finish(goal, ABORTED, f"unknown order {order}", {"status": "aborted"})
            return
        goal.data["location"] = name
        self.navigation.feedback(goal, {"status": f"navigating to {name or 'a random point'}"})

        def done(status: int) -> None:
            text = {SUCCEEDED: "succeeded", PREEMPTED: "preempted"}.get(status, "aborted")
            if goal.status == ACTIVE:
                final = status if status in (SUCCEEDED, PREEMPTED) else ABORTED
                self.navigation.finish(goal, final, text, {"status": text})

        goal.data["move_base_goal"] = self.navigate(*target, done)

    def _navigation_cancel(self, goal: Goal) -> None:
        mb = goal.data.get("move_base_goal")
        if mb is not None and mb.status == ACTIVE:
            mb.data.pop("done", None)
            self.cancel(mb)

    def _step(self, now: float, dt: float) -> None:
        result = self._drive(now)
        goal = self.move_base.current
        if result is not None and goal is not None:
            if result == SUCCEEDED:
                self._finish_move_base(goal, SUCCEEDED, "Goal reached.")
            else:
                self.bus.rosout(8, "/move_base", "Aborting because a valid control could not be found.")
                self._finish_move_base(goal, ABORTED, "Robot is unable to make progress")
            self._pub_plan(force=True)

    # --- path following ------------------------------------------------------------------

    def _follow(self, path: list[tuple[float, float]], goal_yaw: float, now: float) -> None:
        self.path, self.goal_yaw, self.idx, self.active = path, goal_yaw, 0, True
        self._best, self._best_t = math.inf, now

    def _halt(self, now: float) -> None:
        if self.active:
            self.active = False
            self.body.command(0.0, 0.0, now)

    def remaining(self) -> list[tuple[float, float]]:
        if not self.active:
            return []
        return [(self.body.x, self.body.y), *self.path[self.idx + 1:]]

    def _drive(self, now: float) -> int | None:
        """Drive toward the goal; None while under way, then actionlib's SUCCEEDED or ABORTED."""
        if not self.active:
            return None
        b = self.body
        gx, gy = self.path[-1]
        dist = math.hypot(gx - b.x, gy - b.y)
        if dist < self._best - 0.05:
            self._best, self._best_t = dist, now
        elif now - self._best_t > PATIENCE_S:
            self._halt(now)
            return ABORTED
        if dist < XY_TOLERANCE_M:
            err = wrap(self.goal_yaw - b.yaw)
            if abs(err) < YAW_TOLERANCE:
                self._halt(now)
                return SUCCEEDED
            self._best_t = now
            b.command(0.0, max(-MAX_W, min(MAX_W, 2.0 * err)), now)
            return None
        while self.idx < len(self.path) - 1 and math.hypot(self.path[self.idx][0] - b.x,
                                                           self.path[self.idx][1] - b.y) < LOOKAHEAD_M:
            self.idx += 1
        tx, ty = self.path[self.idx]
        err = wrap(math.atan2(ty - b.y, tx - b.x) - b.yaw)
        if abs(err) > 0.8:
            b.command(0.0, math.copysign(MAX_W, err), now)
        else:
            v = min(self.max_v, 0.3 + dist) * max(0.0, math.cos(err))
            b.command(v, max(-MAX_W, min(MAX_W, 2.5 * err)), now)
        return None

    # --- periodic publishers ---------------------------------------------------------------

    def _pub_amcl(self) -> None:
        cov = [0.0] * 36
        cov[0] = cov[7] = 0.02
        cov[35] = 0.01
        self.bus.publish("amcl_pose", {"header": messages.header(ri.MAP_FRAME),
                                       "pose": {"pose": body_pose(self.body), "covariance": cov}})

    def _pub_action_status(self) -> None:
        for server in (self.move_base, self.navigation):
            if self.bus.subs.get(server.status_topic):
                server.publish_status()
            else:
                server.status_message()  # still expire old goals

    def _pub_plan(self, force: bool = False) -> None:
        if not self.bus.wants("plan") or not (force or self.active):
            return
        poses = [{"header": messages.header(ri.MAP_FRAME), "pose": pose(x, y, 0.0)}
                 for x, y in self.remaining()]
        self.bus.publish("plan", {"header": messages.header(ri.MAP_FRAME), "poses": poses})

    def _nav_feedback(self) -> None:
        goal = self.move_base.current
        if goal is not None and self.active:
            self.move_base.feedback(goal, {"base_position": {"header": messages.header(ri.MAP_FRAME),
                                                             "pose": body_pose(self.body)}})
        ngoal = self.navigation.current
        if ngoal is not None:
            self.navigation.feedback(ngoal, {"status": f"navigating to {ngoal.data.get('location') or 'a point'}"})

    def _pub_location(self) -> None:
        b = self.body
        here = next((n for n, loc in self.world.locations.items()
                     if math.hypot(loc.x - b.x, loc.y - b.y) <= loc.threshold), "")
        if here != self.current_location:
            self.current_location = here
            if here:
                self.bus.rosout(2, NAV_NODE, f"Arrived at {here}")
        self.bus.publish("current_location", {"data": here})

    def _nav2_feedback(self, goal: Goal, feedback: dict[str, Any]) -> dict[str, Any]:
        points = [(self.body.x, self.body.y), *self.path[self.idx:]] if self.active else []
        left = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(points))
        return {"current_pose": feedback["base_position"],
                "navigation_time": messages.duration(self.bus.clock.now() - goal.data.get("t0", self.bus.clock.now())),
                "estimated_time_remaining": messages.duration(left / max(self.max_v, 1e-3)),
                "number_of_recoveries": 0, "distance_remaining": left}

    def _map_message(self) -> dict[str, Any]:
        w = self.world
        return grid(w.grid.ravel().tolist(), w.width, w.height, w.resolution, w.origin_x, w.origin_y,
                    self._map_load_time)
