"""Command-line errors that once went their own way, one test each: the command line
answers a bad option or input as every other error (test_one_line_errors.py): one line, exit 2
for usage, 1 for data, nothing written; a misspelled option gets its sub-command's usage."""
from __future__ import annotations

import pytest
from testing.engine_scene import add_camera, add_splats, exr_colour_formats, flat_splats, setup_render
from testing.measured_cli import cli, one_line
from testing.webp_support import STRAIGHT_WEBP

# test64 holds SH degree 3 in every format; SOG reads only where WebP alpha stays straight
IMPORT_FORMATS = ("test64.ply", "test64.glb", "test64.compressed.ply", "test64.spz") + \
    (("test64.sog", "test64_sog_unbundled/meta.json") if STRAIGHT_WEBP else ())


def _usage_error(err: str, command: str, *words) -> None:
    """argparse's answer: the sub-command's usage (not the top level's), then one error line."""
    assert err.startswith(f"usage: python -m addon {command} "), err
    assert "{info,convert" not in err, err  # the top level's usage lists the sub-commands
    errors = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(errors) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in errors[0], err


# --- 1. a misspelled or abbreviated option ----------------------------------------------

@pytest.mark.parametrize("command, args, words", [
    ("render", ("{ply}", "--out", "{out}", "--frmes", "1"), ("--frmes 1", "did you mean --frames?")),
    ("render", ("{ply}", "--out", "{out}", "--hal"), ("--hal", "did you mean --half?")),
    ("convert", ("{ply}", "{out}.spz", "--sh-degre", "1"), ("--sh-degre 1", "did you mean --sh-degree?")),
    ("convert", ("{ply}", "{out}.spz", "--sh-degre=1"), ("--sh-degre=1", "did you mean --sh-degree?")),
    ("info", ("{ply}", "--js"), ("--js", "did you mean --json?")),
    ("import", ("{ply}", "--blend", "{out}.blend", "--max-sh", "1"), ("--max-sh 1",)),
    ("demo", ("--out", "{out}", "--frame", "6"), ("--frame 6", "did you mean --frames?")),
])
def test_misspelled_or_abbreviated_option_is_refused_with_the_sub_command_usage(
        testdata, tmp_path, command, args, words):
    out = tmp_path / "out"
    args = [a.format(ply=testdata / "test64.ply", out=out) for a in args]
    rc, _, err, _ = cli(command, *args, timeout=60)
    assert rc == 2
    _usage_error(err, command, "unrecognized arguments: " + words[0], *words[1:])
    assert list(tmp_path.iterdir()) == []  # nothing written, no folder made


def test_every_parser_refuses_abbreviations():
    from addon.__main__ import COMMANDS, _parser

    parser = _parser()
    (sub,) = [a for a in parser._actions if a.dest == "command"]
    assert not parser.allow_abbrev
    assert sorted(sub.choices) == sorted(COMMANDS)
    assert [name for name, p in sub.choices.items() if p.allow_abbrev] == []


# --- 2. a directory where a file is expected --------------------------------------------

@pytest.mark.parametrize("command, args", [
    ("info", ("{dir}",)),
    ("render", ("{dir}", "--out", "{out}")),
    ("demo", ("--file", "{dir}", "--out", "{out}")),
])
def test_a_directory_input_says_is_a_directory(tmp_path, command, args):
    folder, out = tmp_path / "captures", tmp_path / "out"
    folder.mkdir()
    rc, _, err, _ = cli(command, *[a.format(dir=folder, out=out) for a in args], timeout=60)
    assert rc == 1
    assert one_line(err, f"{folder}: is a directory").endswith("splat file")
    assert not out.exists()


# --- 3. --half where the output is not EXR ----------------------------------------------

@pytest.fixture
def small_blend(bpy_empty, tmp_path):
    """Two splats under a camera, frame 1 at 32x24: saved with PNG output, and with full-float
    multilayer EXR output."""
    from addon.blender.compat import set_file_format

    bpy = bpy_empty
    add_splats(bpy, "splats", flat_splats([(0, 0, 0), (0.5, 0.3, 0.2)], [(0.9, 0.2, 0.1), (0.1, 0.4, 0.9)]))
    add_camera(bpy, location=(0.0, -6.0, 0.0))
    scene = setup_render(bpy, 32, 24)
    scene.frame_start = scene.frame_end = 1
    paths = {}
    for name, fmt in (("png", "PNG"), ("exr", "OPEN_EXR_MULTILAYER")):
        set_file_format(scene.render.image_settings, fmt)
        if fmt != "PNG":
            scene.render.image_settings.color_depth = "32"
        paths[name] = tmp_path / f"{name}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(paths[name]))
    return paths


@pytest.mark.parametrize("args, words", [
    (("{ply}", "--format", "png"), ("not PNG", "--format EXR")),
    (("{ply}", "--format", "mp4"), ("not MP4", "--format EXR")),
    (("{ply}",), ("not PNG (a capture's default)",)),  # refused before Blender starts
    (("{ply}", "--preset", "png_16bit"), ("--preset png_16bit is PNG",)),
    (("{blend}",), ("{blend} is PNG",)),  # the .blend's own output settings
])
def test_half_where_the_output_is_not_exr_is_refused(testdata, small_blend, tmp_path, args, words):
    out = tmp_path / "out"
    fill = {"ply": testdata / "test64.ply", "blend": small_blend["png"]}
    args = [a.format(**fill) for a in args]
    rc, _, err, _ = cli("render", *args, "--out", out, "--frames", "1", "--half", timeout=120)
    assert rc == 2
    one_line(err, "--half", "EXR", *[w.format(**fill) for w in words])
    assert not out.exists()


@pytest.mark.parametrize("args", [("{ply}", "--preset", "exr_float"), ("{blend}",)])
def test_half_applies_to_a_preset_or_blend_whose_output_is_exr(testdata, small_blend, tmp_path, args):
    """Full-float EXR from the preset or the .blend; --half overrides it, as other flags do."""
    fill = {"ply": testdata / "test64.ply", "blend": small_blend["exr"]}
    args = [a.format(**fill) for a in args]
    for half, want in ((False, {"float"}), (True, {"half"})):
        out = tmp_path / f"out_{half}"
        rc, _, err, _ = cli("render", *args, "--out", out, "--frames", "1", "--resolution", "32x24",
                            *(["--half"] if half else []), timeout=120)
        assert rc == 0, err
        (frame,) = out.glob("*.exr")
        assert exr_colour_formats(frame) == want


# --- 4. --engine-option names -----------------------------------------------------------

def test_engine_option_lists_only_render_settings(testdata, tmp_path):
    out = tmp_path / "out"
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", out, "--engine-option", "foo=bar",
                        timeout=120)
    assert rc == 2  # a usage error
    line = one_line(err, "--engine-option 'foo=bar'")
    listed = line.split("NAME one of ", 1)[1].split(", ")
    assert "renderer" in listed and "key_bits" in listed
    assert "name" not in listed and "rna_type" not in listed  # every PropertyGroup's, not settings
    rc, _, err, _ = cli("render", testdata / "test64.ply", "--out", out, "--engine-option", "name=x",
                        timeout=120)
    assert rc == 2  # a usage error; it was accepted: it renamed the settings group
    one_line(err, "--engine-option 'name=x'")
    assert not out.exists()


# --- 5. a file named .blend that Blender cannot read ------------------------------------

@pytest.fixture
def fake_blends(small_blend, tmp_path):
    text = tmp_path / "text.blend"
    text.write_text("not a blend file\n")
    cut = tmp_path / "cut.blend"
    cut.write_bytes(small_blend["png"].read_bytes()[:3000])  # starts with Blender's header
    header = tmp_path / "header.blend"
    header.write_bytes(b"BLENDER-v300REND")  # the header, then nothing
    return {"text": text, "cut": cut, "header": header}


@pytest.mark.parametrize("kind", ["text", "cut", "header"])
@pytest.mark.parametrize("command", ["render", "convert"])
def test_a_fake_blend_is_one_line(fake_blends, tmp_path, kind, command):
    path, out = fake_blends[kind], tmp_path / "out"
    args = ("--out", out) if command == "render" else (out.with_suffix(".spz"),)
    rc, stdout, err, _ = cli(command, path, *args, timeout=120)
    assert rc == 1
    line = one_line(err, f"{path}: cannot open: ")
    assert line.count(str(path)) == 1 and "Error" not in line, line  # named once, no "Error:"
    # Blender's own "Error: ..." report is held back (stdout may hold Blender's start-up
    # lines: "Using config from OCIO" where the OCIO variable is set, as bpy sets it for us)
    assert "Error" not in stdout and path.name not in stdout, stdout
    assert not out.exists() and not out.with_suffix(".spz").exists()


def test_a_good_blend_still_prints_blenders_lines(small_blend, tmp_path):
    """What Blender prints while opening a good file is held back only until it opened."""
    out = tmp_path / "out"
    rc, stdout, err, _ = cli("render", small_blend["png"], "--out", out, "--frames", "1", timeout=120)
    assert rc == 0, err
    assert stdout.index(f'Read blend: "{small_blend["png"]}"') < stdout.index("rendering 1 frame(s)")


# --- 6. demo --out that is a file -------------------------------------------------------

def test_demo_out_that_is_a_file_names_it(tmp_path):
    path = tmp_path / "taken"
    path.write_text("mine")
    rc, _, err, _ = cli("demo", "--out", path, timeout=60)
    assert rc == 1
    line = one_line(err, f"--out {path}: exists and is not a folder")
    assert "File exists" not in line
    assert path.read_text() == "mine"


# --- 7. import reports the file's own SH degree -----------------------------------------

def test_import_reports_the_files_sh_degree_not_the_cap(testdata, tmp_path):
    paths = [testdata / name for name in IMPORT_FORMATS]
    rc, out, err, _ = cli("import", *paths, "--max-sh-degree", "1", "--blend", tmp_path / "x.blend",
                          timeout=180)
    assert rc == 0, err
    for path in paths:
        (line,) = [ln for ln in out.splitlines() if ln.startswith(f"{path}: ")]
        assert line.endswith("SH degree 3 -> 1"), line  # a .glb, .sog, compressed .ply said 1 -> 1


@pytest.mark.parametrize("name", IMPORT_FORMATS)
@pytest.mark.parametrize("cap", [0, 1, 2, 3])
def test_read_report_gives_the_files_degree_under_any_cap(testdata, name, cap):
    from addon.core.formats import read_with_report

    full, _ = read_with_report(testdata / name)
    splats, report = read_with_report(testdata / name, sh_degree=cap)
    assert full.sh_degree == 3
    assert (report.sh_degree_in_file, splats.sh_degree) == (3, cap)
