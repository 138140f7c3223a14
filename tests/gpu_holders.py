"""Arrays as a simulation holds them on a GPU, for tests that Python scenes read them as rays are read."""

import numpy as np


def wp_array(values, device="cpu"):
    """``values`` as a contiguous ``wp.array`` on ``device``."""
    import warp as wp

    return wp.array(np.ascontiguousarray(values), device=device)


class DLPackOnly:
    """An array numpy cannot read but DLPack hands over, as a ``torch`` tensor on CUDA is ("can't convert cuda:0
    device type tensor to numpy"): a CPU Warp array behind ``__dlpack__`` only."""

    def __init__(self, values):
        self.warp = wp_array(values)

    def __dlpack__(self, stream=None):
        return self.warp.__dlpack__(stream=stream)

    def __dlpack_device__(self):
        return self.warp.__dlpack_device__()

    def __array__(self, dtype=None, copy=None):
        raise TypeError("can't convert cuda:0 device type tensor to numpy")
