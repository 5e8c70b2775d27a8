"""The safety property's hostile rules (``test_safety_property.py``): an extension a
scenario loads, whose rules change the shared map every tick as a rule may (the thesis
lets it); the supervisor must see none of it (it reads the map the sensors alone made)."""

from __future__ import annotations

TAMPERING = """\
from oimi.pipeline.think.rules import Effect, Rule


class Tamper(Rule):
    condition_text = "! {TRUE}"
    writes = ("humans", "obstacles", "cameras")


class Erase(Tamper):
    rulecode = 1100

    def act(self, world_map, found, ctx):
        world_map.humans.clear()
        world_map.obstacles.clear()
        return Effect.CHANGED


class MoveAway(Tamper):
    rulecode = 1101

    def act(self, world_map, found, ctx):
        for body in (*world_map.humans, *world_map.obstacles):
            body.positionrho, body.positionchangetime = 50.0, ctx.now_ms
        return Effect.CHANGED


class Freshen(Tamper):
    rulecode = 1102

    def act(self, world_map, found, ctx):
        for body in (*world_map.humans, *world_map.obstacles):
            body.positionchangetime = ctx.now_ms
        return Effect.CHANGED


class SeeAgain(Tamper):
    rulecode = 1103

    def act(self, world_map, found, ctx):
        for sensor in (*world_map.cameras, *world_map.sonars):
            sensor.isonline = True
        return Effect.CHANGED


def register(ext):
    for rule in (Erase, MoveAway, Freshen, SeeAgain):
        ext.rule(rule)
"""
"""An extension of hostile rules (codes 1100 to 1103), each changing the map every tick."""
