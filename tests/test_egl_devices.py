"""Which EGL device a batch worker of one GPU draws on (gpu/context.py choose_egl_device): the
device that reports the worker's CUDA device (EGL_NV_device_cuda) where the driver says it, EGL's
index order elsewhere. Fake device lists stand for machines with several NVIDIA GPUs (there is
no GPU here); the enumeration itself runs on this machine's EGL."""

from __future__ import annotations

import pytest

from depthimpostor.errors import ContextError
from depthimpostor.gpu.context import EglChoice, EglDevice, choose_egl_device, egl_device_for_gpu, egl_devices

NV = "EGL_NV_device_cuda EGL_EXT_device_drm"
MESA = "EGL_MESA_device_software"


def nvidia(*cuda: int | None) -> list[EglDevice]:
    """EGL's devices in its order, each with the CUDA device it reports (None: none, such as Mesa's
    software device, or a GPU hidden by CUDA_VISIBLE_DEVICES)."""
    return [EglDevice(index, number, NV if number is not None else MESA) for index, number in enumerate(cuda)]


def test_the_device_reporting_the_gpus_cuda_number_is_chosen_whatever_egls_order() -> None:
    devices = nvidia(2, 3, 0, 1, None)  # EGL's order is not CUDA's, and ends with a software device
    chosen = [choose_egl_device(devices, str(gpu), None).index for gpu in range(4)]
    assert chosen == [2, 3, 0, 1]
    assert choose_egl_device(devices, "1", None).how == "EGL_CUDA_DEVICE_NV 1 (CUDA_VISIBLE_DEVICES=None)"


def test_a_ray_worker_sees_its_gpu_as_cuda_device_0() -> None:
    """Ray sets CUDA_VISIBLE_DEVICES=3 for GPU 3: CUDA numbers the devices the process sees, so GPU 3
    is CUDA device 0 there, and the other GPUs report none."""
    devices = nvidia(None, None, 0, None)
    assert choose_egl_device(devices, "3", "3").index == 2
    # A worker given two GPUs draws on its first; numbers count the visible devices in their order.
    assert choose_egl_device(nvidia(None, 1, 0, None), "5", "5,2").index == 2
    assert choose_egl_device(nvidia(None, 1, 0, None), "2", "5, 2").index == 1
    # Ids as UUIDs (CUDA_VISIBLE_DEVICES=GPU-...) are matched by their place alike.
    assert choose_egl_device(nvidia(0, None), "GPU-8a3f", "GPU-8a3f").index == 0


def test_without_the_extension_egls_index_order_is_kept() -> None:
    devices = [EglDevice(0, None, MESA), EglDevice(1, None, "EGL_EXT_device_drm")]
    choice = choose_egl_device(devices, "1", "1")
    assert choice.index == 1 and choice.how == "index 1: no EGL device has EGL_NV_device_cuda"
    with pytest.raises(ContextError, match="no EGL device for GPU GPU-8a3f: no EGL device has EGL_NV_device_cuda"):
        choose_egl_device(devices, "GPU-8a3f", "GPU-8a3f")


@pytest.mark.parametrize(("devices", "gpu", "visible", "why"), [
    # An old driver reported one CUDA device for several GPUs (MapD's EglDisplayManager works around it).
    (nvidia(0, 0), "0", None, "index 0: 2 EGL devices report CUDA device 0"),
    (nvidia(1, 2), "0", None, "index 0: 0 EGL devices report CUDA device 0"),
    (nvidia(0, 1), "3", "1,2", "index 3: GPU 3 is not among CUDA_VISIBLE_DEVICES=1,2"),
])
def test_a_mapping_that_names_no_single_device_falls_back_to_the_index(devices: list[EglDevice], gpu: str,
                                                                      visible: str | None, why: str) -> None:
    assert choose_egl_device(devices, gpu, visible) == EglChoice(int(gpu), why)


def test_one_device_reporting_the_number_is_enough_whatever_the_others_report() -> None:
    assert choose_egl_device(nvidia(0, 0, 1), "1", None).index == 2


def test_this_machines_egl_devices_are_enumerated() -> None:
    """Mesa's (llvmpipe) devices report no CUDA device: a worker keeps EGL's index order."""
    devices = egl_devices()
    assert devices and [device.index for device in devices] == list(range(len(devices)))
    assert all(device.cuda is None for device in devices) or any("EGL_NV_device_cuda" in d.extensions for d in devices)
    if all(device.cuda is None for device in devices):
        assert egl_device_for_gpu("0") == choose_egl_device(devices, "0", None)
        assert egl_device_for_gpu("0").how == "index 0: no EGL device has EGL_NV_device_cuda"
