"""What wrt's options accept: the names (accelerators, BVH builders and layouts, AOVs, preview colourings) and the
limits (samples, bounces, exposure, rays, leaf sizes, bins, pre-split levels) that the library checks and the command
line lists.

Plain Python, without Warp: ``wrt --help`` and ``wrt render --help`` read them here instead of importing the modules
whose kernels use them (with Warp, numpy and usd-core, 1.9 s of CPU on a 2-core VM, where the help takes 0.08 s). Each
of those modules imports its own from here, so ``wrt.render.MAX_SPP`` and ``wrt.bvh.build.Builder`` are these objects.
"""

from __future__ import annotations

import enum

from .wording import did_you_mean

# Renders (wrt.render)
DEFAULT_MAX_DEPTH = {"path": 10, "whitted": 8}  # surface interactions per path
QUICK_LOOKS = ("normals", "depth", "albedo")  # integrators whose image is made from the AOVs (one sample)
DATA_INTEGRATORS = ("normals", "depth")  # their images are data (Image.data): a PNG stores them unencoded
MAX_DEPTH = 1024  # one launch per bounce; the kernels take it as a 32-bit int (2^32 + 2 wrapped onto 2)
MAX_SPP = 0x7FFFFFFF  # the kernels number samples with a 32-bit int: sample 2^31 wrapped to -2^31 (unjittered)
# Beyond +-150 stops every float32 radiance is 0 or white after scaling; 2.0**1024 overflows a Python float.
MAX_EXPOSURE = 150.0  # of Image.save (wrt.image)
# The keys of Image.aovs: the per-pixel buffers of wrt.render's _AovBuffers.SPEC, in its order, and coverage.
AOV_NAMES = ("depth", "z", "normal", "geometric_normal", "albedo", "prim", "instance", "material", "cost", "coverage")

# Accelerators (wrt.trace)
ACCELERATORS = ("wrt", "warp")  # names accepted by accel=
# Pre-split levels of the SAH trees that accelerators build (``bvh/presplit.py``): the same hits, and on an H200 a
# 2M-triangle UV sphere's primary rays traced 1.52x faster (its poles' slivers), other ray kinds 0.96-1.04x
# (GPU_NOTES.md, row 41).
ACCELERATOR_PRESPLIT = 6

# BVH builds (wrt.bvh)
ALIASES = {"binned_sah": "sah"}  # alternative names -> canonical builder name
DEFAULT_LEAF_SIZE = 8  # most triangles per leaf of build_bvh_device
DEFAULT_BINS = 16  # SAH bins per axis of build_bvh_device
MAX_BINS = 64  # upper bound on SAH bins per axis
MAX_LEAF_SIZE = 1 << 16  # upper bound on leaf_size
MAX_SPLIT_LEVELS = 6  # at most 2^6 references per triangle
EPO_SAMPLES = 1 << 16  # default number of surface samples for the EPO estimate
MAX_EPO_SAMPLES = 1 << 24  # most samples: about 80 bytes of host arrays each; 1e9 asked for 80 GB (stderr ~ 1/sqrt(n))
LAYOUTS = ("binary", "compact", "wide", "wide8")  # names accepted by layout=
WARP_BUILDERS = ("sah", "median", "lbvh", "cubql")  # wp.Mesh bvh_constructor values
WARP_PREFIX = "warp:"  # builder names of the form "warp:<bvh_constructor>" read wp.Mesh's tree (bvh-stats)
MAX_WARP_LEAF_SIZE = 2**31 - 1  # Warp reads bvh_leaf_size as a C int: 2^31 wrapped and crashed the process

# Previews (wrt.preview)
TRIANGLE_BUDGET = 2_000_000  # most triangles drawn; larger scenes are simplified by vertex clustering
MAX_RAYS = 1_000_000  # most sample rays: each is a drawn line (3e5 take 2 s to draw; 1e8 would need GBs)
BVH_COLORINGS = ("depth", "sah")  # values of bvh_color


class Builder(enum.Enum):
    """Builder names shared by wrt and Warp's ``wp.Mesh(bvh_constructor=...)`` where they mean the same thing."""

    SAH = "sah"  # binned SAH ("binned_sah" is an alias)
    SWEEP_SAH = "sweep_sah"  # full-sweep SAH over presorted centroids
    MEDIAN = "median"  # object median on the axis of largest centroid extent
    MIDDLE = "middle"  # spatial median of the centroid bounds on the widest axis
    LBVH = "lbvh"  # Morton codes + Karras radix tree
    PLOC = "ploc"  # bottom-up agglomerative clustering

    @classmethod
    def from_str(cls, name: str) -> Builder:
        """Parses a builder name; raises ``ValueError`` listing the valid names. Names are lower case and exact, as
        every other name wrt takes (``'SAH'`` is refused naming ``'sah'``): ``wrt bvh-stats --builder SAH`` and ``wrt
        bench --accels wrt:SAH`` were taken where ``wrt render --builder SAH`` and ``--accels warp:SAH`` were not."""
        key = ALIASES.get(str(name), str(name))
        for b in cls:
            if b.value == key:
                return b
        raise ValueError(f"unknown BVH builder {name!r}{did_you_mean(name, builder_names())}; valid builders: "
                         f"{', '.join(builder_names())}")


def builder_names() -> list[str]:
    """Every accepted builder name, canonical names first, then aliases."""
    return [b.value for b in Builder] + list(ALIASES)


def parse_builders(text) -> list[str]:
    """Builder names from a comma-separated list (or a list of them); ``all`` means every wrt builder.

    Raises:
        ValueError: for an unknown wrt or Warp builder name.
    """
    items = text if isinstance(text, (list, tuple)) else [text]
    names = []
    for item in items:
        for name in str(item).split(","):
            name = name.strip()
            if not name:
                continue
            if name == "all":
                names += [b.value for b in Builder]
            elif name.startswith(WARP_PREFIX):
                if name[len(WARP_PREFIX) :] not in WARP_BUILDERS:
                    valid = [WARP_PREFIX + b for b in WARP_BUILDERS]
                    raise ValueError(f"unknown Warp builder {name!r}{did_you_mean(name, valid)}; valid Warp builders: "
                                     f"{', '.join(valid)}")
                names.append(name)
            else:
                try:
                    names.append(Builder.from_str(name).value)
                except ValueError:  # matched against wrt's builders alone, 'wrp:sah' meant 'sweep_sah'
                    every = [*builder_names(), "all", *(WARP_PREFIX + b for b in WARP_BUILDERS)]
                    kind, _, builder = name.partition(":")
                    # 'wrt:sah', as wrt bench names wrt's accelerator, was told 'did you mean warp:sah': Warp's tree
                    meant = (f" (did you mean {builder!r}? wrt's builders are named without wrt bench's 'wrt:')"
                             if kind == "wrt" and builder in builder_names() else did_you_mean(name, every))
                    raise ValueError(f"unknown BVH builder {name!r}{meant}; valid builders: "
                                     f"{', '.join(every)}") from None
    if not names:
        raise ValueError(f"no builder given; valid builders: {', '.join(builder_names())}, all, warp:<name>")
    return list(dict.fromkeys(names))
