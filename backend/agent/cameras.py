"""Camera sources: the interface the capture loop uses, and its pypylon implementation.

A real station runs Basler GigE cameras hardware-triggered by the wheel sensor
(`trigger_source = "Line1"`); tests and demos run pylon's camera emulation
(``PYLON_CAMEMU=N``) with software triggers, each emulated camera replaying a folder of
PNG frames (`replay_dir`). The emulator reads a folder in file-name order and delivers the
files' pixels unchanged for Mono8 (8-bit files) and Mono16 (16-bit files); for Mono10/Mono12 it
converts a 16-bit file to the format's depth (value >> 6, value >> 4).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from backend.agent.station import SensorConfig, Station

EMULATED_DEVICE_CLASS = "BaslerCamEmu"
_MAX_BUFFERS = 32


class CameraError(OSError):
    """A camera cannot be found, opened or configured; one line naming sensor and camera."""


class GrabFailed(Exception):
    """A camera did not deliver a frame; `reason` says why in words for the server."""

    def __init__(self, reason: str, *, lost: bool = False) -> None:
        super().__init__(reason)
        self.reason = reason
        self.lost = lost


class CameraSource(Protocol):
    """What the capture loop needs from one camera."""

    @property
    def sensor(self) -> SensorConfig:
        """The station's configuration of this camera."""
        ...

    def grab(self) -> np.ndarray:
        """Trigger (when software-triggered) and return one frame, (M, N) uint8 or uint16.

        Raises GrabFailed when no frame arrives within the sensor's timeout or the camera
        is gone (`lost=True`: no later frame will come either).
        """
        ...

    def close(self) -> None:
        """Stop grabbing and release the device."""
        ...


@dataclass(frozen=True, slots=True)
class DeviceSummary:
    """What enumeration says about one attached camera."""

    serial: str
    user_id: str
    model: str
    device_class: str


def list_devices() -> list[DeviceSummary]:
    """Cameras pylon sees now (GigE, USB and, with PYLON_CAMEMU=N, emulated ones)."""
    from pypylon import pylon

    return [
        DeviceSummary(
            d.GetSerialNumber(), d.GetUserDefinedName(), d.GetModelName(), d.GetDeviceClass()
        )
        for d in pylon.TlFactory.GetInstance().EnumerateDevices()
    ]


def open_cameras(
    station: Station, *, allow_missing: bool
) -> tuple[dict[str, CameraSource], dict[str, str]]:
    """Open and configure every camera of the station.

    Returns
    -------
    cameras : dict of sensor → CameraSource
        The cameras found and configured.
    missing : dict of sensor → str
        Sensors whose camera was not found, with the reason (only with `allow_missing`).

    Raises
    ------
    CameraError
        A camera is not attached (unless `allow_missing`) or refuses its configuration.
    """
    from pypylon import pylon

    factory = pylon.TlFactory.GetInstance()
    devices = list(factory.EnumerateDevices())
    cameras: dict[str, CameraSource] = {}
    missing: dict[str, str] = {}
    try:
        for config in station.sensors:
            match = [
                d for d in devices if config.camera in (d.GetSerialNumber(), d.GetUserDefinedName())
            ]
            if not match:
                reason = f"camera {config.camera!r} for {config.sensor} is not attached"
                if not allow_missing:
                    seen = ", ".join(d.GetSerialNumber() for d in devices) or "none"
                    raise CameraError(f"{reason} (cameras seen: {seen})")
                missing[config.sensor] = reason
                continue
            cameras[config.sensor] = PylonCamera(factory.CreateDevice(match[0]), config, station)
    except BaseException:
        for camera in cameras.values():
            camera.close()
        raise
    return cameras, missing


class PylonCamera:
    """One Basler camera through pypylon, configured from the station file and grabbing."""

    def __init__(self, device: object, config: SensorConfig, station: Station) -> None:
        from pypylon import genicam, pylon

        self._pylon = pylon
        self._genicam = genicam
        self._config = config
        self._camera = pylon.InstantCamera(device)
        self._label = f"{config.sensor} ({config.camera})"
        try:
            self._camera.Open()
            self._configure(station)
            self._camera.MaxNumBuffer.Value = _MAX_BUFFERS
            self._camera.StartGrabbing(pylon.GrabStrategy_OneByOne)
        except genicam.GenericException as exc:
            self.close()
            raise CameraError(f"camera {self._label}: {_first_line(exc)}") from None

    @property
    def sensor(self) -> SensorConfig:
        """The station's configuration of this camera."""
        return self._config

    def _configure(self, station: Station) -> None:
        camera, config = self._camera, self._config
        camera.PixelFormat.Value = config.pixel_format
        for name, value in (("Width", station.image_width_px), ("Height", station.image_height_px)):
            node = getattr(camera, name)
            if value > node.Max:
                raise CameraError(f"camera {self._label}: {name} {value} px > sensor's {node.Max}")
            node.Value = value
        exposure = "ExposureTime" if _has(camera, "ExposureTime") else "ExposureTimeAbs"
        getattr(camera, exposure).Value = config.exposure_us
        camera.TriggerSelector.Value = "FrameStart"
        camera.TriggerMode.Value = "On"
        camera.TriggerSource.Value = config.trigger_source
        if config.replay_dir is not None:
            self._configure_replay(config.replay_dir)

    def _configure_replay(self, folder: os.PathLike[str]) -> None:
        camera = self._camera
        device_class = camera.GetDeviceInfo().GetDeviceClass()
        if device_class != EMULATED_DEVICE_CLASS:
            raise CameraError(
                f"camera {self._label}: replay_dir needs an emulated camera, this is {device_class}"
            )
        if not os.path.isdir(folder):
            raise CameraError(f"camera {self._label}: replay_dir {folder} is not a folder")
        camera.TestImageSelector.Value = "Off"
        camera.ImageFileMode.Value = "On"
        camera.ImageFilename.Value = os.fspath(folder)

    def grab(self) -> np.ndarray:
        """Trigger (software trigger only) and return one frame; raises GrabFailed."""
        pylon, camera = self._pylon, self._camera
        timeout_ms = max(1, round(self._config.timeout_s * 1000))
        try:
            if self._config.trigger_source == "Software":
                if not camera.WaitForFrameTriggerReady(timeout_ms, pylon.TimeoutHandling_Return):
                    raise GrabFailed(f"camera {self._label} not ready for a trigger")
                camera.ExecuteSoftwareTrigger()
            result = camera.RetrieveResult(timeout_ms, pylon.TimeoutHandling_Return)
        except self._genicam.GenericException as exc:
            lost = not camera.IsGrabbing() or camera.IsCameraDeviceRemoved()
            raise GrabFailed(
                f"camera {self._label} failed: {_first_line(exc)}", lost=lost
            ) from None
        if not result.IsValid():
            raise GrabFailed(
                f"camera {self._label} delivered no frame within {self._config.timeout_s:g} s"
            )
        try:
            if not result.GrabSucceeded():
                raise GrabFailed(
                    f"camera {self._label} frame incomplete: {result.ErrorDescription.strip()}"
                )
            return np.array(result.Array, copy=True)
        finally:
            result.Release()

    def close(self) -> None:
        """Stop grabbing and release the device (safe to call twice)."""
        camera = self._camera
        try:
            if camera.IsGrabbing():
                camera.StopGrabbing()
            camera.Close()
            camera.DestroyDevice()
        except self._genicam.GenericException:
            return


def _has(camera: object, name: str) -> bool:
    try:
        return getattr(camera, name) is not None and getattr(camera, name).IsWritable()
    except Exception:  # pypylon raises its own LogicalErrorException for an unknown node
        return False


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
