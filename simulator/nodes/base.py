"""RosAria and robot_pose_publisher: the Pioneer base, its odometry, tf, battery, motors, bumpers and sonar."""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable
from typing import Any

from .. import messages, world
from ..bus import Bus, SimNode

NODE = "/RosAria"
SONAR_X = 0.1  # the sonar ring's offset ahead of base_link
SONAR_MAX_M = 5.0


class BaseNode(SimNode):
    names = ("/RosAria", "/robot_pose_publisher")
    publishes = ("robot_pose", "odom", "tf", "tf_static", "sonar", "bumper_state", "battery_soc",
                 "battery_voltage", "battery_recharge_state", "motors_state")
    answers = ("enable_motors", "disable_motors")

    def __init__(self, body: world.Base, world_map: world.WorldMap, rng: random.Random, pose_rate_hz: float,
                 soc: float, drain_per_s: float, charge_per_s: float) -> None:
        self.body = body
        self.world = world_map
        self.rng = rng
        self.pose_rate_hz = pose_rate_hz
        self.soc = soc
        self.drain = drain_per_s
        self.charge = charge_per_s
        self.recharge_state = 0
        self.bumper_until = 0.0
        # The event scheduler's answer to a low battery: True once the controller took "power_low".
        self.battery_low: Callable[[], bool] = lambda: False
        self._low_battery_fired = False
        self.odom_seq = 0  # header.seq, counted per publisher as roscpp does (a recorder can find gaps)

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("cmd_vel", self._cmd_vel)
        bus.answer("enable_motors", lambda r: self.set_motors(True))
        bus.answer("disable_motors", lambda r: self.set_motors(False))
        bus.each_tick(self._step)
        bus.every(1.0 / self.pose_rate_hz, self._pub_pose)
        bus.every(1.0 / 25.0, self._pub_tf, wanted="tf")
        bus.every(0.2, self._pub_sonar, wanted="sonar")
        bus.every(0.5, self._pub_bumper)
        bus.every(1.0, self._pub_battery)
        bus.every(1.0, lambda: bus.publish("motors_state", {"data": self.body.motors}))
        bus.publish("tf_static", {"transforms": [
            world.transform("base_link", "laser", 0.2, 0.0, 0.0),
            world.transform("base_link", "sonar", SONAR_X, 0.0, 0.0),
        ]})

    def voltage(self) -> float:
        # A 24 V nominal pack (Pioneer LX): ~23 V empty, ~26 V full, +1.2 V while charging.
        return 23.0 + 3.0 * self.soc + (1.2 if self.recharge_state > 0 else 0.0)

    def set_motors(self, on: bool) -> dict[str, Any]:
        self.body.motors = on
        if not on:
            self.body.command(0.0, 0.0, self.bus.clock.now())
        self.bus.rosout(2, NODE, f"Motors {'enabled' if on else 'disabled'}")
        self.bus.publish("motors_state", {"data": on})
        return {}

    def _cmd_vel(self, m: dict[str, Any]) -> None:
        if not self.body.motors:
            self.bus.warn_once("motors_off", NODE, "Motors are disabled: ignoring cmd_vel", 5.0)
            return
        self.body.command(m["linear"]["x"], m["angular"]["z"], self.bus.clock.now())

    def _step(self, now: float, dt: float) -> None:
        if self.body.step(dt, now):
            self.bumper_until = now + 0.5
            self._pub_bumper()
            self.bus.warn_once("bump", NODE, "Bumper pressed: the robot hit an obstacle")
        self._battery(dt)

    def _battery(self, dt: float) -> None:
        b = self.body
        dock = self.world.locations.get("charging_station")
        docked = dock is not None and math.hypot(b.x - dock.x, b.y - dock.y) < dock.threshold and b.v == 0.0
        if docked:
            self.soc = min(1.0, self.soc + self.charge * dt)
            self.recharge_state = 1 if self.soc < 0.9 else 3
        else:
            moving = abs(b.v) + 0.3 * abs(b.w)
            self.soc = max(0.0, self.soc - self.drain * (1.0 + 4.0 * moving) * dt)
            self.recharge_state = 0
        if self.soc < 0.2 and not docked:
            self.bus.warn_once("battery_low", NODE, f"Battery low: {100 * self.soc:.0f}%", 60.0)
            if not self._low_battery_fired and self.battery_low():
                self._low_battery_fired = True
        elif self.soc > 0.3:
            self._low_battery_fired = False

    def _pub_pose(self) -> None:
        bus, b = self.bus, self.body
        if bus.wants("robot_pose"):
            bus.publish("robot_pose", world.body_pose(b))
        # Numbered at the robot's rate whether or not anyone listens: a gap in the numbers is time unwatched.
        self.odom_seq += 1
        if bus.wants("odom"):
            cov = [0.0] * 36
            bus.publish("odom", {
                "header": messages.header("odom", time.time(), self.odom_seq), "child_frame_id": "base_link",
                "pose": {"pose": world.pose(b.odom_x, b.odom_y, b.odom_yaw), "covariance": cov},
                "twist": {"twist": {"linear": {"x": b.v, "y": 0.0, "z": 0.0},
                                    "angular": {"x": 0.0, "y": 0.0, "z": b.w}}, "covariance": cov},
            })

    def _pub_tf(self) -> None:
        b = self.body
        self.bus.publish("tf", {"transforms": [
            world.transform("map", "odom", *b.map_from_odom()),
            world.transform("odom", "base_link", b.odom_x, b.odom_y, b.odom_yaw),
        ]})

    def sonar(self) -> list[tuple[float, float]]:
        """(angle, range) of the ring's 8 sonars, from the ring itself (the "sonar" frame, SONAR_X
        ahead of base_link on /tf_static) across the front half."""
        return self.world.fan(self.body, SONAR_X, math.pi, 8, SONAR_MAX_M)

    def bumpers(self) -> tuple[bool, bool]:
        """(front, rear) pressed: for half a second after a bump, on the side the base was driving."""
        hit = self.bus.clock.now() < self.bumper_until
        front = hit and self.body.cmd_v >= 0
        return front, hit and not front

    def _pub_sonar(self) -> None:
        points = [{"x": d * math.cos(a), "y": d * math.sin(a), "z": 0.0} for a, d in self.sonar()]
        self.bus.publish("sonar", {"header": messages.header("sonar"), "points": points, "channels": []})

    def _pub_bumper(self) -> None:
        if self.bus.wants("bumper_state"):
            front, rear = self.bumpers()
            self.bus.publish("bumper_state", {"header": messages.header("base_link"),
                                              "front_bumpers": [front] * 5, "rear_bumpers": [rear] * 5})

    def _pub_battery(self) -> None:
        self.bus.publish("battery_soc", {"data": self.soc})
        self.bus.publish("battery_voltage", {"data": self.voltage() + self.rng.gauss(0, 0.02)})
        self.bus.publish("battery_recharge_state", {"data": self.recharge_state})
