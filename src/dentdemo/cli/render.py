"""`dentdemo render`: a scene simulated at its fixed dt and drawn headless (EGL) to PNG frames."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from dentdemo.cli.args import (
    add_compact_state,
    add_gltf,
    add_quality,
    add_scene,
    check_gltf,
    command,
    float_in,
    int_in,
    size_wxh,
)
from dentdemo.errors import DentdemoError
from dentdemo.extras import require_app
from dentdemo.outputs import PNG, check_output_dir, check_output_file


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "render",
        "simulate a scene headless (EGL) and write PNG frames",
        "dentdemo render --frames 240 --size 1280x720 --out ball_drop.png",
    )
    add_scene(p)
    p.add_argument(
        "--frames", type=int_in(1, 10**7), default=120, help="simulation frames at the scene's dt"
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="PNG",
        help="output image; %%04d in it writes every frame, %%%% a literal %%",
    )
    p.add_argument("--size", type=size_wxh, default="1280x720", metavar="WxH", help="pixels")
    p.add_argument(
        "--maps-dir", metavar="DIR", help="also write every body's height and normal maps"
    )
    p.add_argument("--no-dents", action="store_true", help="detect impacts but carve nothing")
    p.add_argument("--parallax", action="store_true", help="parallax occlusion mapping")
    p.add_argument(
        "--no-displace",
        action="store_true",
        help="draw deep dents in the maps only, not in the outline (see 'dentdemo info')",
    )
    p.add_argument(
        "--view", type=int, choices=(0, 1, 2), default=0, help="0 shaded, 1 height, 2 normals"
    )
    p.add_argument(
        "--save-state",
        metavar="DIR",
        help="after the last frame, save every body's maps and the physics state to DIR",
    )
    add_compact_state(p, "--save-state writes")
    p.add_argument(
        "--load-state",
        metavar="DIR",
        help="resume a state saved from the same scene; --frames then continues it",
    )
    add_quality(p)
    p.add_argument(
        "--video",
        metavar="FILE",
        help="also write every frame to a video: .mp4 (H.264) or .gif, at the scene's frame rate",
    )
    add_gltf(
        p, "also write every body as it is after the last frame, with its normal and height maps"
    )
    p.add_argument(
        "--hit-log",
        metavar="FILE",
        help="also write every carve as a record: .ddhl (binary) or .jsonl (JSON Lines);"
        " 'dentdemo replay' carves it back",
    )
    p.add_argument(
        "--eye",
        type=float_in(-1000, 1000),
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="camera position, world metres (default: the scene's camera)",
    )
    p.add_argument(
        "--target",
        type=float_in(-1000, 1000),
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="point the camera looks at, world metres",
    )
    p.add_argument(
        "--fov",
        type=float_in(1.0, 170.0),
        default=None,
        metavar="DEG",
        help="vertical field of view, degrees (default: the scene's)",
    )
    p.set_defaults(handler=run)


#: One frame number in a file name: %d, optionally zero-padded to a width (%04d).
FRAME_NUMBER = re.compile(r"%0?[0-9]*d")


def frame_pattern(out: Path) -> bool:
    """True when `out` names one file per frame (one %d-style number; %% is a literal %); any
    other % pattern (%s, %x, two numbers) is an error, so that the names written are the
    names reported."""
    rest = out.name.replace("%%", "")
    if "%" not in rest:
        return False
    if len(FRAME_NUMBER.findall(rest)) != 1 or rest.count("%") != 1:
        raise DentdemoError(
            f"--out: '{out.name}' has a bad % pattern (use one %04d, and %% for a literal %)"
        )
    return True


def _folder(flag: str, text: str | None) -> Path | None:
    """A folder flag's path; an empty one is an error, not the same as leaving the flag out."""
    if text is None:
        return None
    if not text.strip():
        raise DentdemoError(f"{flag}: '{text}' is not a folder name")
    return Path(text)


def run(args: argparse.Namespace) -> int:
    from dentdemo.app.headless import render_headless
    from dentdemo.render.renderer import RenderOptions

    if not args.out.strip():
        raise DentdemoError(f"--out: '{args.out}' is not a file name")
    out = Path(args.out)
    every = frame_pattern(out)
    if not every and "%" in out.name:
        out = out.with_name(out.name % ())  # only %% in it: one file, each %% a literal %
    check_output_file("--out", out.with_name(out.name % 0) if every else out, PNG)
    maps_dir = _folder("--maps-dir", args.maps_dir)
    load_state = _folder("--load-state", args.load_state)
    if maps_dir is not None:
        check_output_dir("--maps-dir", maps_dir)
    video = None
    if args.video is not None:
        video = check_output_file("--video", args.video, (".mp4", ".gif"))
        if video.suffix.lower() == ".mp4":
            require_app("--video: an MP4", "imageio_ffmpeg")
        if video.suffix.lower() == ".mp4" and (args.size[0] % 2 or args.size[1] % 2):
            raise DentdemoError(f"--video: H.264 needs an even --size, got {args.size}")
    gltf = check_gltf(args.gltf)
    hit_log = None
    if args.hit_log is not None:
        from dentdemo.app.hitlog import check_log_path

        if args.load_state:
            raise DentdemoError(
                "--hit-log: a log starts from the scene as loaded; it cannot follow --load-state"
            )
        hit_log = check_log_path("--hit-log", Path(args.hit_log))
    save_state = _folder("--save-state", args.save_state)
    if args.compact_state is not None and save_state is None:
        raise DentdemoError("--compact-state: it shapes --save-state, which is not given")
    if save_state is not None:
        from dentdemo.app.state import check_state_dir

        check_state_dir("--save-state", save_state)
    render_headless(
        Path(args.scene),
        args.materials,
        args.frames,
        out,
        args.size,
        maps_dir,
        denting=not args.no_dents,
        options=RenderOptions(
            parallax=args.parallax, view=args.view, displace=not args.no_displace
        ),
        every_frame=every,
        load_state=load_state,
        save_state=save_state,
        quality=args.quality,
        eye=tuple(args.eye) if args.eye is not None else None,
        target=tuple(args.target) if args.target is not None else None,
        fov=args.fov,
        video=video,
        progress=True,
        gltf=gltf,
        hit_log=hit_log,
        compact_every=args.compact_state,
    )
    if every:
        last = args.frames - 1
        print(f"wrote {out.with_name(out.name % 0)} ... {out.with_name(out.name % last)}")
    else:
        print(f"wrote {out}")
    if gltf is not None:
        print(f"wrote {gltf}")
    if hit_log is not None:
        print(f"wrote {hit_log}")
    return 0
