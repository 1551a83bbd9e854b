"""``nld scenes`` (the built-in scenes, one per line) and ``nld show`` (resolved parameters)."""
from __future__ import annotations

from nld.cli.args import scene_args


def add_parser(sub) -> None:
    sp = sub.add_parser("scenes", help="list the built-in scenes", description="List the built-in scenes.")
    sp.set_defaults(func=cmd_scenes)
    sp = sub.add_parser("show", help="print the resolved scene parameters with units",
                        description="Print the resolved scene parameters with units.")
    scene_args(sp)
    sp.set_defaults(func=cmd_show)


def cmd_scenes(args) -> int:
    from nld.model.scene import builtin_scenes
    scenes = builtin_scenes()
    width = max((len(n) for n in scenes), default=0)
    for name, desc in scenes.items():
        print(f"{name:<{width}}  {desc}".rstrip())
    return 0


def cmd_show(args) -> int:
    from nld.model.scene import format_scene, load_scene
    scene = load_scene(args.scene, args.overrides)
    print(format_scene(scene))
    return 0
