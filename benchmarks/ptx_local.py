"""Local-memory traffic and registers of the trace kernels, from the PTX that Warp's bundled NVRTC generates.

No GPU is needed: each module is compiled ahead of time (``wp.compile_aot_module``, PTX for ``--arch``) into a
scratch folder, then every kernel entry of the PTX is scanned for ``ld.local`` / ``st.local`` instructions and its
``__local_depot`` size (bytes of per-thread local memory). With ``ptxas`` on the PATH, ``ptxas -v`` adds the
registers, stack frame and spill bytes of the SASS; with ``nvdisasm`` too (CUDA toolkit, or the
``nvidia-cuda-nvdisasm`` wheel), the SASS's own local stores and loads (``STL`` / ``LDL``), where spills show up
that the PTX does not have. A vec3 indexed by a runtime value, a zeroed in-kernel array or a spill all show up here
as local traffic on every ray.

    python benchmarks/ptx_local.py [--arch 90] [--package wrt] [--kernels trace_bvh_kernel,...]
"""

from __future__ import annotations

import argparse
import importlib
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import warp as wp

MODULES = ("trace", "tlas", "bvh.compact", "bvh.wide")  # modules of the package that hold trace kernels


def ptx_entries(ptx: str) -> dict[str, str]:
    """``entry name -> body`` of each ``.entry`` in a PTX file."""
    starts = [(m.start(), m.group(1)) for m in re.finditer(r"\.entry\s+(\w+)", ptx)]
    ends = [s for s, _ in starts[1:]] + [len(ptx)]
    return {name: ptx[s:end] for (s, name), end in zip(starts, ends)}


def assemble(ptx_path: Path, arch: int) -> tuple[str, Path | None]:
    """``(report, cubin)``: ``ptxas -v``'s report on the PTX and the cubin it wrote (``None`` if it wrote none); an
    empty report and no cubin without ptxas."""
    if not shutil.which("ptxas"):
        return "", None
    cubin = ptx_path.with_suffix(".cubin")
    source = ptx_path
    for _ in range(2):
        cmd = ["ptxas", "-v", f"-arch=sm_{arch}", "-o", str(cubin), str(source)]
        report = subprocess.run(cmd, check=False, capture_output=True, text=True).stderr
        m = re.search(r"Unsupported \.version \S+; current version is '(\S+)'", report)
        if not m or source != ptx_path:
            break
        # NVRTC may be newer than ptxas: relabel the PTX (the trace kernels use no newer PTX feature) and drop the
        # trailing NUL that NVRTC leaves in the file.
        source = ptx_path.with_suffix(".old.ptx")
        text = ptx_path.read_text().rstrip("\0")
        source.write_text(re.sub(r"^\.version \S+", f".version {m.group(1)}", text, flags=re.MULTILINE))
    return report, cubin if cubin.exists() else None


def ptxas_info(report: str) -> dict[str, str]:
    """``entry name -> 'R regs, F B stack, S/L B spill'`` from a ``ptxas -v`` report."""
    info, name, props = {}, None, None
    for line in report.splitlines():
        if m := re.search(r"Compiling entry function '(\w+)'", line):
            name = m.group(1)
        elif m := re.search(r"Function properties for (\w+)", line):
            props = m.group(1)  # an entry's or a called (non-inlined) function's
        elif name and props == name and (m := re.search(r"(\d+) bytes stack frame, (\d+) bytes spill stores, "
                                                        r"(\d+) bytes spill loads", line)):
            info[name] = f"{m.group(1)} B stack, {m.group(2)}/{m.group(3)} B spill"
        elif name and (m := re.search(r"Used (\d+) registers", line)):
            info[name] = f"{m.group(1)} regs, " + info.get(name, "")
    return info


def sass_local(cubin: Path | None) -> dict[str, str]:
    """``entry name -> 'STL s, LDL l'``: the local stores and loads in each kernel's SASS, read back from the cubin
    by ``nvdisasm``; empty without a cubin or nvdisasm."""
    if cubin is None or not shutil.which("nvdisasm"):
        return {}
    sass = subprocess.run(["nvdisasm", "-c", str(cubin)], check=False, capture_output=True, text=True).stdout
    counts = {}
    for section in re.split(r"^\s*\.section\s+\.text\.", sass, flags=re.MULTILINE)[1:]:
        entry = re.match(r"(\w+)", section).group(1)
        stores, loads = len(re.findall(r"\bSTL\b", section)), len(re.findall(r"\bLDL\b", section))
        counts[entry] = f"STL {stores}, LDL {loads}"
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--arch", type=int, default=90, help="SM architecture of the PTX")
    parser.add_argument("--package", default="wrt", help="package to inspect (e.g. wrt_old with --path)")
    parser.add_argument("--path", help="folder to put first on sys.path (holding --package)")
    parser.add_argument("--kernels", default="", help="comma list of kernel name prefixes (default: all)")
    args = parser.parse_args()
    sys.path.insert(0, str(Path(args.path).resolve()) if args.path else str(Path(__file__).resolve().parents[1]))
    wp.config.quiet = True
    wp.config.enable_backward = False
    wp.init()
    wanted = [k for k in args.kernels.split(",") if k]
    print(f"{'kernel':32s} {'st.local':>8s} {'ld.local':>8s} {'depot B':>7s}  ptxas")
    with tempfile.TemporaryDirectory() as tmp:
        for mod_name in MODULES:
            module = importlib.import_module(f"{args.package}.{mod_name}")
            out = Path(tmp) / mod_name
            wp.compile_aot_module(module, arch=args.arch, module_dir=out, use_ptx=True)
            for ptx_path in sorted(out.glob("*.ptx")):
                ptx = ptx_path.read_text()
                report, cubin = assemble(ptx_path, args.arch)
                info, sass = ptxas_info(report), sass_local(cubin)
                for entry, body in ptx_entries(ptx).items():
                    kernel = re.sub(r"_[0-9a-f]{7,}_cuda_kernel_forward$", "", entry)
                    if wanted and not any(kernel.startswith(w) for w in wanted):
                        continue
                    depot = re.search(r"\.local \.align \d+ \.b8 \s*__local_depot\d+\[(\d+)\]", body)
                    stores, loads = len(re.findall(r"st\.local", body)), len(re.findall(r"ld\.local", body))
                    depot_bytes = depot.group(1) if depot else "0"
                    print(f"{kernel:32s} {stores:8d} {loads:8d} {depot_bytes:>7s}  {info.get(entry, '')}"
                          + (f"; SASS {sass[entry]}" if entry in sass else ""))


if __name__ == "__main__":
    main()
