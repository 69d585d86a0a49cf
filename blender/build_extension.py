"""Builds the Blender extension's installable zip: the add-on's files, its manifest and the
ragdoll_sim wheel(s) under wheels/.

    python blender/build_extension.py --wheel wheels/ragdoll_sim-*.whl -o ragdoll-blender.zip

Install it with Edit > Preferences > Get Extensions > Install from Disk. Blender cannot
unload a native module: after installing a new version, restart Blender.
"""

import argparse
import pathlib
import re
import sys
import zipfile

HERE = pathlib.Path(__file__).resolve().parent
ADDON = HERE / "ragdoll_blender"

# The platform tag of a wheel, as the extension manifest names it.
PLATFORMS = {
    "manylinux": "linux-x64",
    "musllinux": "linux-x64",
    "win_amd64": "windows-x64",
    "macosx": "macos-arm64",
}


def platform(wheel):
    tag = wheel.name.rsplit("-", 1)[-1]
    if "aarch64" in tag:
        return "linux-arm64" if "linux" in tag else "windows-arm64"
    if "macosx" in tag and "x86_64" in tag:
        return "macos-x64"
    for key, name in PLATFORMS.items():
        if key in tag:
            return name
    raise SystemExit(f"{wheel}: no Blender platform for the wheel tag {tag!r}")


def build(wheels, out):
    manifest = (ADDON / "blender_manifest.toml").read_text()
    names = [f"./wheels/{w.name}" for w in wheels]
    platforms = sorted({platform(w) for w in wheels})
    manifest = re.sub(r"(?m)^wheels = \[.*\]$", "wheels = [" + ", ".join(f'"{n}"' for n in names) + "]", manifest)
    manifest = re.sub(r"(?m)^platforms = \[.*\]$", "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]", manifest)
    tmp = out.with_suffix(".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        for f in sorted(ADDON.glob("*.py")):
            z.write(f, f.name)
        for w in wheels:
            z.write(w, f"wheels/{w.name}")
    tmp.replace(out)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wheel", action="append", required=True, type=pathlib.Path,
                    help="a ragdoll_sim wheel to bundle (give one per platform)")
    ap.add_argument("-o", "--output", type=pathlib.Path, default=pathlib.Path("ragdoll-blender.zip"))
    a = ap.parse_args(argv)
    for w in a.wheel:
        if not w.is_file():
            raise SystemExit(f"{w}: no such wheel")
    print(build(a.wheel, a.output))


if __name__ == "__main__":
    sys.exit(main())
