"""Per-wheel data of a pass (frames, masks, σ maps, centres, profile) and wheel trends.

Images are PNG (downscaled with `max_width`); centres and profiles are columnar JSON
(equal-length arrays) that the browser draws directly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal, cast

import numpy as np
from fastapi import APIRouter, Depends, Query, Request, Response
from sqlalchemy.orm import Session

from backend.api.deps import PassWheelDep, SessionDep, StoreDep, ViewerDep, WheelDep
from backend.api.schemas import (
    CentresRead,
    ErrorRead,
    PassWheelRead,
    ProfileRead,
    Sensor,
    WheelTrend,
)
from backend.errors import ERROR_RESPONSES
from backend.services.images import (
    SIGMA_COLORMAP,
    SIGMA_SCALES_PX,
    frame_png,
    mask_layer,
    sigma_layer,
    sigma_map_of,
)
from backend.services.queries import pass_wheels
from backend.services.trends import wheel_trend
from backend.services.wheel_data import (
    retained_frame,
    stored_artefacts,
    stored_extraction,
    wheel_profile,
)
from backend.storage.artefacts import FrameArtefacts
from backend.storage.store import BlobStore
from db.models import Frame, MeasurementFrame, PassWheel

router = APIRouter(prefix="/api", tags=["wheels"], responses=ERROR_RESPONSES)

Position = Literal["inner", "outer"]
Method = Literal["adaptive", "steger"]
WHEEL = "/passes/{pass_id}/wheels/{wheel_id}"
PNG: dict[int | str, dict[str, Any]] = {
    200: {"content": {"image/png": {}}, "description": "PNG image"},
}
FRAME_PNG: dict[int | str, dict[str, Any]] = {
    **PNG,
    410: {"model": ErrorRead, "description": "the frame was removed by frame retention"},
}
MaxWidth = Annotated[int | None, Query(ge=16, le=8192, description="downscale to this width [px]")]
REVALIDATE = {"Cache-Control": "private, no-cache"}
"""Browsers keep the layers and ask again with If-None-Match (a 304 costs one lookup)."""
FrameIndex = Annotated[int, Query(ge=0, description="frame of this sensor for the wheel, 0-based")]


@dataclass(frozen=True, slots=True)
class FrameLayer:
    """One frame's stored extraction, as the layer routes (mask, σ, centres) address it."""

    position: Position
    pass_wheel: PassWheel
    session: Session
    store: BlobStore
    method: Method
    index: int

    def extraction(self) -> tuple[Frame, MeasurementFrame]:
        """The frame row and its stored extraction row (404 when not measured)."""
        return stored_extraction(
            self.session, self.pass_wheel, self.method, self.position, self.index
        )

    def artefacts(self) -> tuple[Frame, FrameArtefacts]:
        """The frame row and its decoded artefacts (centres, mask, σ map)."""
        return stored_artefacts(
            self.session, self.store, self.pass_wheel, self.method, self.position, self.index
        )


def _frame_layer(
    position: Position,
    pass_wheel: PassWheelDep,
    session: SessionDep,
    store: StoreDep,
    method: Method = "adaptive",
    index: FrameIndex = 0,
) -> FrameLayer:
    return FrameLayer(position, pass_wheel, session, store, method, index)


FrameLayerDep = Annotated[FrameLayer, Depends(_frame_layer)]


def _revalidated(request: Request, etag: str) -> Response | None:
    """304 when the browser already holds this version (all layers are content-addressed)."""
    if request.headers.get("if-none-match") == etag:
        return Response(status_code=304, headers={"ETag": etag, **REVALIDATE})
    return None


@router.get(WHEEL)
def get_pass_wheel(
    pass_wheel: PassWheelDep, session: SessionDep, _viewer: ViewerDep
) -> PassWheelRead:
    """One wheel of a pass: identity, state, parameters per method, alarms."""
    return pass_wheels(session, pass_wheel.train_pass, only=[pass_wheel])[0]


@router.get(WHEEL + "/frames/{position}.png", response_class=Response, responses=FRAME_PNG)
def get_frame_png(
    request: Request,
    position: Position,
    pass_wheel: PassWheelDep,
    session: SessionDep,
    store: StoreDep,
    _viewer: ViewerDep,
    index: FrameIndex = 0,
    max_width: MaxWidth = None,
) -> Response:
    """A frame of the wheel's inner or outer sensor as PNG (8/16-bit grey as recorded);
    410 once frame retention removed the pass's frames."""
    frame = retained_frame(session, pass_wheel, position, index)
    etag = f'"{frame.sha256[:24]}-{max_width}"'
    if (cached := _revalidated(request, etag)) is not None:
        return cached
    data = frame_png(store.get(frame.sha256, ".png"), max_width)
    headers = {"X-Frame-Sha256": frame.sha256, "ETag": etag, **REVALIDATE}
    return Response(data, media_type="image/png", headers=headers)


@router.get(WHEEL + "/mask/{position}.png", response_class=Response, responses=PNG)
def get_mask_png(
    request: Request,
    layer: FrameLayerDep,
    _viewer: ViewerDep,
    max_width: MaxWidth = None,
) -> Response:
    """The stripe mask the method searched centres in (255 = stripe, 96 = candidate centres
    the method rejected)."""
    _frame_row, row = layer.extraction()
    etag = f'"{row.artefact_sha256[:24]}-mask-{max_width}"'
    if (cached := _revalidated(request, etag)) is not None:
        return cached
    data = mask_layer(layer.store, row, max_width)
    return Response(data, media_type="image/png", headers={"ETag": etag, **REVALIDATE})


@router.get(WHEEL + "/sigma/{position}.png", response_class=Response, responses=PNG)
def get_sigma_png(
    request: Request,
    layer: FrameLayerDep,
    _viewer: ViewerDep,
    max_width: MaxWidth = None,
) -> Response:
    """The σ map coloured (transparent where no scale was chosen). Its colour scale is in
    the headers X-Colormap, X-Sigma-Min-Px and X-Sigma-Max-Px (σ1 and σ3 of the configured
    width range, the same for every frame), the scales σ1, σ2, σ3 in X-Sigma-Scales-Px."""
    _frame_row, row = layer.extraction()
    etag = f'"{row.artefact_sha256[:24]}-sigma-{max_width}"'
    png = sigma_layer(layer.store, row, layer.method, max_width)
    headers = {
        "X-Colormap": SIGMA_COLORMAP,
        "X-Sigma-Min-Px": f"{png.sigma_min_px}",
        "X-Sigma-Max-Px": f"{png.sigma_max_px}",
        "X-Sigma-Scales-Px": ",".join(f"{sigma:.4f}" for sigma in SIGMA_SCALES_PX),
        "ETag": etag,
        **REVALIDATE,
    }
    if (cached := _revalidated(request, etag)) is not None:
        cached.headers.update(headers)
        return cached
    return Response(png.png, media_type="image/png", headers=headers)


@router.get(
    WHEEL + "/sigma/{position}.f32",
    response_class=Response,
    responses={200: {"content": {"application/octet-stream": {}}}},
)
def get_sigma_raw(
    layer: FrameLayerDep,
    _viewer: ViewerDep,
) -> Response:
    """The raw σ map [px]: row-major little-endian float32, 0 outside the mask; the size
    is in the headers X-Width-Px and X-Height-Px (a Float32Array in the browser)."""
    _frame_row, artefacts = layer.artefacts()
    sigma_map = sigma_map_of(artefacts, layer.method)
    height_px, width_px = sigma_map.shape
    return Response(
        np.ascontiguousarray(sigma_map, "<f4").tobytes(),
        media_type="application/octet-stream",
        headers={"X-Width-Px": str(width_px), "X-Height-Px": str(height_px)},
    )


@router.get(WHEEL + "/centres/{position}")
def get_centres(
    layer: FrameLayerDep,
    _viewer: ViewerDep,
) -> CentresRead:
    """Centre points of one frame, columnar: x, y [px], sigma [px], strength, nx, ny, and
    the candidates the method rejected (rejected_x, rejected_y [px])."""
    frame, artefacts = layer.artefacts()
    points = {name: np.round(values, 4).tolist() for name, values in artefacts.points.items()}
    rejected = np.round(artefacts.rejected_xy, 4)
    return CentresRead(
        method=layer.method,
        sensor=cast(Sensor, frame.sensor),
        seq=frame.seq,
        width_px=frame.width_px,
        height_px=frame.height_px,
        count=len(points["x"]),
        **points,
        rejected_x=rejected[:, 0].tolist(),
        rejected_y=rejected[:, 1].tolist(),
    )


@router.get(WHEEL + "/profile")
def get_profile(
    pass_wheel: PassWheelDep, _viewer: ViewerDep, method: Method = "adaptive"
) -> ProfileRead:
    """The fused profile and its reference profile [mm], with the Sh/Sd/qR construction."""
    return wheel_profile(pass_wheel, method)


@router.get("/wheels/{wheel_id}/trend")
def get_trend(wheel: WheelDep, session: SessionDep, _viewer: ViewerDep) -> WheelTrend:
    """One wheel across passes, oldest first: its parameters per method and alarms, the
    limits that apply and a wear forecast per parameter."""
    return wheel_trend(session, wheel)
