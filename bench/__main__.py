"""Run every benchmark table (or only those named: python -m bench import render)."""
from __future__ import annotations

import importlib
import sys

TABLES = (
    "formats_bench", "plyfile_bench", "import_bench", "reference_bench", "render_bench", "viewport_bench",
    "effects_bench", "sequence_bench", "engine_bench", "engine_paths_bench", "final_frame_bench",
    "cli_frame_bench", "colour_profile_bench", "native_engines_bench", "handoff_bench", "holdout_bench",
    "mesh_layer_bench", "film_convert_bench", "render_result_fill_bench", "frame_digests", "dynamic_bench",
    "dynamic_scrub_bench", "framing_bench", "instances_bench", "native_instances_bench", "lighting_bench",
    "ksplat_bench", "lighting_frame_bench",
)


def main(argv) -> int:
    chosen = [t for t in TABLES if not argv or any(a in t for a in argv)]
    for name in chosen:
        module = importlib.import_module(f"bench.{name}")
        print(f"\n=== {name} ===", flush=True)
        module.main()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
