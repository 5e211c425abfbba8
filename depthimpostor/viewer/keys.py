"""The viewer's controls: one table that the key handler, the help overlay, docs/guide.md and the
`--keys` script all read, and the parser of scripted key presses.

Keys are named as glfw names them without the KEY_ prefix, in lower case (`left_bracket`,
`page_up`, `f12`, `escape`), or by the character they type on a US layout (`[`, `=`, `a`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import Enum, auto

import glfw

from ..errors import DepthImpostorError


class Action(Enum):
    TURN_LEFT = auto()
    TURN_RIGHT = auto()
    TURN_UP = auto()
    TURN_DOWN = auto()
    ZOOM_IN = auto()
    ZOOM_OUT = auto()
    TOGGLE_FLY = auto()
    HOME = auto()
    NEXT_ALGORITHM = auto()
    NEXT_METHOD = auto()
    RESOLUTION_UP = auto()
    RESOLUTION_DOWN = auto()
    TOGGLE_SAMPLES = auto()
    TOGGLE_RETRACED = auto()
    RELOAD_SHADERS = auto()
    SCREENSHOT = auto()
    TOGGLE_HELP = auto()
    TOGGLE_PANEL = auto()
    QUIT = auto()


@dataclass(frozen=True)
class Binding:
    action: Action
    keys: tuple[str, ...]
    help: str
    repeats: bool = False  # acts again while the key is held (glfw's key repeat)


#: Degrees per press of an arrow key.
TURN_STEP_DEGREES = 5.0

BINDINGS: tuple[Binding, ...] = (
    Binding(Action.TURN_LEFT, ("left",), f"turn the view {TURN_STEP_DEGREES:g} deg left (orbiting or flying)", True),
    Binding(Action.TURN_RIGHT, ("right",), f"turn the view {TURN_STEP_DEGREES:g} deg right", True),
    Binding(Action.TURN_UP, ("up",), f"orbit {TURN_STEP_DEGREES:g} deg higher (fly: look up)", True),
    Binding(Action.TURN_DOWN, ("down",), f"orbit {TURN_STEP_DEGREES:g} deg lower (fly: look down)", True),
    Binding(Action.ZOOM_IN, ("page_up",), "zoom in", True),
    Binding(Action.ZOOM_OUT, ("page_down",), "zoom out", True),
    Binding(Action.TOGGLE_FLY, ("f",), "fly mode on/off: W A S D move, Q E down/up, Shift faster, mouse looks"),
    Binding(Action.HOME, ("home",), "back to the scene's camera"),
    Binding(Action.NEXT_ALGORITHM, ("tab",), "next intersection algorithm (basic, optimized, hierarchical)"),
    Binding(Action.NEXT_METHOD, ("m",), "next approximation method"),
    Binding(Action.RESOLUTION_UP, ("]", "="), "double the depth-image resolution (re-bakes them)"),
    Binding(Action.RESOLUTION_DOWN, ("[", "-"), "halve the depth-image resolution (re-bakes them)"),
    Binding(Action.TOGGLE_SAMPLES, ("v",), "show the depth images' samples instead of the objects"),
    Binding(Action.TOGGLE_RETRACED, ("t",), "hybrid method: tint magenta the rays traced against the real triangles"),
    Binding(Action.RELOAD_SHADERS, ("r",), "reload the shaders (a broken one is reported, the last good kept)"),
    Binding(Action.SCREENSHOT, ("f12", "p"), "save a numbered screenshot, without the overlay"),
    Binding(Action.TOGGLE_HELP, ("h", "f1"), "show or hide this help"),
    Binding(Action.TOGGLE_PANEL, ("f2",), "show or hide the panel of controls and views"),
    Binding(Action.QUIT, ("escape",), "quit"),
)

MOUSE_CONTROLS: tuple[tuple[str, str], ...] = (
    ("left drag", "orbit around the target (fly mode: move the mouse to look)"),
    ("right or middle drag", "pan"),
    ("wheel", "zoom toward the target"),
)

#: Keys held down in fly mode, polled every frame: (key, axis, sign) with axes forward, right, lift.
FLY_KEYS: tuple[tuple[str, str, int], ...] = (
    ("w", "forward", 1), ("s", "forward", -1), ("d", "right", 1), ("a", "right", -1),
    ("e", "lift", 1), ("q", "lift", -1),
)

_CHARACTER_KEYS = {
    "[": "left_bracket", "]": "right_bracket", "-": "minus", "=": "equal", ",": "comma", ".": "period",
    "/": "slash", ";": "semicolon", "'": "apostrophe", "\\": "backslash", "`": "grave_accent", "esc": "escape",
}
KEY_CODES: dict[str, int] = {
    name[len("KEY_"):].lower(): getattr(glfw, name)
    for name in dir(glfw)
    if name.startswith("KEY_") and name not in ("KEY_UNKNOWN", "KEY_LAST")
}
KEY_CODES.update({alias: KEY_CODES[name] for alias, name in _CHARACTER_KEYS.items()})
MODIFIERS = {"shift": glfw.MOD_SHIFT, "ctrl": glfw.MOD_CONTROL, "alt": glfw.MOD_ALT}

ACTIONS_BY_KEY: dict[int, Binding] = {KEY_CODES[key]: binding for binding in BINDINGS for key in binding.keys}


def key_name(code: int) -> str:
    """The name a key is written with in `--keys` (the character where it has one)."""
    names = [name for name, value in KEY_CODES.items() if value == code]
    return min(names, key=len) if names else f"key {code}"


class KeyScriptError(DepthImpostorError):
    """A `--keys` script names a key the viewer does not know."""

    exit_code = 2


@dataclass(frozen=True)
class KeyPress:
    """One scripted frame: a key pressed and released before the frame is drawn, or none (wait)."""

    key: int | None
    mods: int = 0
    token: str = "wait"


_TOKEN = re.compile(r"^(?P<mods>(?:(?:shift|ctrl|alt)\+)*)(?P<key>.+?)(?:\*(?P<count>\d+))?$")


def parse_key_script(text: str) -> list[KeyPress]:
    """Whitespace-separated tokens `[shift+|ctrl+|alt+]KEY[*COUNT]`, or `wait[*COUNT]` for
    frames without a key; one press per frame, in order."""
    presses: list[KeyPress] = []
    for number, token in enumerate(text.split(), start=1):
        match = _TOKEN.match(token.lower())
        name = match.group("key") if match else token
        count = int(match.group("count") or 1) if match else 1
        if match is None or (name != "wait" and name not in KEY_CODES):
            raise KeyScriptError(
                f"--keys: token {number} ({token!r}): expected [shift+|ctrl+|alt+]KEY[*COUNT] or wait[*COUNT], "
                "where KEY is a character such as ] or p, or a glfw key name such as left, page_up, f12, escape"
            )
        mods = sum(MODIFIERS[m] for m in match.group("mods").split("+") if m)
        press = KeyPress(None, 0, token) if name == "wait" else KeyPress(KEY_CODES[name], mods, token)
        presses += [press] * count
    return presses


def _key_list(keys: tuple[str, ...]) -> str:
    return " or ".join(f"`{key}`" if key != "`" else "backtick" for key in keys)


def help_lines() -> list[str]:
    """The overlay's help: every control on a line, a tab between the control and what it does."""
    lines = [f"{control}\t{what}" for control, what in MOUSE_CONTROLS]
    lines += [f"{' / '.join(binding.keys)}\t{binding.help}" for binding in BINDINGS]
    return lines


def controls_markdown() -> str:
    """The table of controls in docs/guide.md, made from the same table the viewer reads."""
    rows = ["| control | what it does |", "|---|---|"]
    rows += [f"| {control} | {what} |" for control, what in MOUSE_CONTROLS]
    rows += [f"| {_key_list(binding.keys)} | {binding.help} |" for binding in BINDINGS]
    return "\n".join(rows)
