"""Pydantic request and response models of the HTTP API (units in the field names)."""

from __future__ import annotations

import re
from datetime import UTC, datetime
from typing import Annotated, Any, Generic, Literal, TypeVar

from pydantic import (
    AfterValidator,
    AwareDatetime,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    computed_field,
    model_validator,
)

from db.types import MAX_INTEGER

Role = Literal["viewer", "operator", "admin"]
Side = Literal["left", "right"]
Sensor = Literal["left_inner", "left_outer", "right_inner", "right_outer"]

_ISO_DATE_TIME = re.compile(r"^\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}")


def _iso_text(value: object) -> object:
    """Only ISO 8601 text is a date (pydantic would read a number as Unix seconds)."""
    if isinstance(value, datetime):
        return value
    if not isinstance(value, str) or not _ISO_DATE_TIME.match(value):
        raise ValueError("must be an ISO 8601 date-time such as 2026-05-01T00:00:00Z")
    return value


def _in_utc(value: datetime) -> datetime:
    try:
        return value.astimezone(UTC)
    except OverflowError:
        raise ValueError("lies outside years 1–9999 once converted to UTC") from None


UtcDateTime = Annotated[AwareDatetime, BeforeValidator(_iso_text), AfterValidator(_in_utc)]
"""An ISO 8601 date-time with a time zone, converted to UTC (years 1–9999 in UTC)."""

CALIBRATION_DOCUMENT_SCHEMA: dict[str, Any] = {
    "type": "object",
    "required": ["format", "sensors"],
    "properties": {
        "format": {"const": "wheelscan-calibration/1"},
        "sensors": {
            "type": "object",
            "minProperties": 1,
            "propertyNames": {"enum": ["left_inner", "left_outer", "right_inner", "right_outer"]},
        },
    },
    "description": "a wheelscan-calibration/1 object; every sensor's intrinsics, laser plane "
    "(|d| ≥ 1 mm) and rigid camera_to_track transform are checked (422 names the fault)",
}
"""What a JSON Schema can say of a calibration document; the parser checks the rest."""
CalibrationDocument = Annotated[
    dict[str, Any], Field(json_schema_extra=CALIBRATION_DOCUMENT_SCHEMA)
]


def _find_nul(value: object, where: str) -> str | None:
    """The dotted name of the first text (or key) in `value` holding a NUL, else None."""
    if isinstance(value, str):
        return where if "\x00" in value else None
    if isinstance(value, dict):
        pairs: Any = value.items()
    elif isinstance(value, list | tuple):
        pairs = enumerate(value)
    else:
        return None
    for key, item in pairs:
        name = f"{where}.{key}" if where else str(key)
        found = name if "\x00" in str(key) else _find_nul(item, name)
        if found is not None:
            return found
    return None


class InputModel(BaseModel):
    """A request body: no text in it may hold a NUL character (PostgreSQL cannot store one,
    so SQLite must not accept it either)."""

    @model_validator(mode="after")
    def _no_nul(self) -> InputModel:
        where = _find_nul(self.model_dump(), "")
        if where is not None:
            raise ValueError(f"{where} must not contain NUL characters")
        return self


class ORMModel(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class ErrorRead(BaseModel):
    detail: str
    code: str


class Health(BaseModel):
    status: Literal["ok"]
    database: str
    pipeline_version: str
    version: str


class Me(BaseModel):
    """Who the presented token is."""

    role: Role
    name: str
    prefix: str


class TokenCreate(InputModel):
    role: Role
    name: str = Field(min_length=1, max_length=100)
    expires_at: UtcDateTime | None = Field(
        default=None, description="must lie in the future (422 otherwise); none: never expires"
    )


class TokenRead(ORMModel):
    id: int
    name: str
    role: Role
    prefix: str
    created_at: datetime
    expires_at: datetime | None
    revoked_at: datetime | None


class TokenCreated(TokenRead):
    token: str = Field(description="the bearer token; shown only once")


class SiteCreate(InputModel):
    name: str = Field(min_length=1, max_length=100, pattern=r"^[^/]+$")


class SiteRead(ORMModel):
    id: int
    name: str
    created_at: datetime
    current_calibration_version: int | None = None
    rail_profile: str = Field(default="60E1", description="rails the conicity is computed on")
    rail_inclination: str = Field(default="1:40", description="rail inclination to the centre")
    gauge_mm: float = Field(default=1435.0, description="track gauge, 14 mm below the rail top")


class SiteRails(InputModel):
    """The rails a site's wheelsets run on, for the equivalent conicity of its axles."""

    rail_profile: Literal["60E1", "54E1"]
    rail_inclination: Literal["1:40", "1:20"]
    gauge_mm: float = Field(ge=1400, le=1470)


class CalibrationCreate(InputModel):
    document: CalibrationDocument
    note: str | None = Field(default=None, max_length=1000)


class CalibrationRead(ORMModel):
    id: int
    site_id: int
    version: int
    sha256: str
    note: str | None
    registered: bool
    created_at: datetime
    document: dict[str, Any]


class LimitsRead(ORMModel):
    fleet: str
    wheel_profile: Literal["EN", "LM"]
    flange_height_min_mm: float
    flange_height_max_mm: float
    flange_thickness_min_mm: float
    flange_thickness_max_mm: float
    qr_min_mm: float
    back_to_back_min_mm: float
    back_to_back_max_mm: float
    conicity_max: float = Field(description="equivalent conicity (3 mm) alarm threshold")
    updated_at: datetime
    near_limit_fraction: float = Field(description="amber band: fraction of each limit band")
    method_disagreement_mm: float = Field(description="flag adaptive − Steger beyond this [mm]")


class LimitsUpdate(InputModel):
    """New limits; each *_min_mm must lie below its *_max_mm (422 otherwise)."""

    flange_height_min_mm: float = Field(gt=0, lt=100)
    flange_height_max_mm: float = Field(gt=0, lt=100)
    flange_thickness_min_mm: float = Field(gt=0, lt=100)
    flange_thickness_max_mm: float = Field(gt=0, lt=100)
    qr_min_mm: float = Field(gt=0, lt=100)
    back_to_back_min_mm: float = Field(gt=1000, lt=2000)
    back_to_back_max_mm: float = Field(gt=1000, lt=2000)
    near_limit_fraction: float | None = Field(
        default=None, ge=0, le=0.5, description="amber band; omitted: kept as it is"
    )
    method_disagreement_mm: float | None = Field(
        default=None, gt=0, le=20, description="omitted: kept as it is [mm]"
    )
    conicity_max: float = Field(default=0.4, gt=0, lt=2)


class PassAccepted(BaseModel):
    pass_id: int
    job_id: int


class StreamOpen(InputModel):
    """A pass to stream into; without `calibration`, the site's registered one is used (422
    when the site has none)."""

    site: str = Field(min_length=1, max_length=100)
    started_at: UtcDateTime
    direction: str | None = Field(default=None, max_length=40)
    speed_kmh: float | None = Field(default=None, ge=0, le=500)
    odometer_km: dict[str, Annotated[float, Field(ge=0, le=1e8)]] | None = Field(
        default=None, description="odometer readings of the vehicles at this pass {id: km}"
    )
    frames_per_sensor: int = Field(default=1, ge=1, le=1000)
    calibration: CalibrationDocument | None = None


class FramePut(BaseModel):
    sha256: str
    wheel_complete: bool


class FrameRead(ORMModel):
    sensor: Sensor
    seq: int
    sha256: str
    vehicle_id: str
    axle: int


SENSOR_ON_ITS_SIDE: dict[str, Any] = {
    "anyOf": [
        {
            "properties": {
                "side": {"const": "left"},
                "sensor": {"enum": ["left_inner", "left_outer"]},
            }
        },
        {
            "properties": {
                "side": {"const": "right"},
                "sensor": {"enum": ["right_inner", "right_outer"]},
            }
        },
    ]
}
"""The schema's way of saying a missing sensor must be one of the wheel's side."""


class MissingSensor(InputModel):
    model_config = ConfigDict(json_schema_extra=SENSOR_ON_ITS_SIDE)

    vehicle_id: str = Field(min_length=1, max_length=100)
    axle: int = Field(ge=0, le=MAX_INTEGER)
    side: Side
    sensor: Sensor
    reason: str = Field(min_length=1, max_length=500)


class WheelStateRead(BaseModel):
    vehicle_id: str
    axle: int
    side: Side
    state: str
    reason: str | None


class JobRead(ORMModel):
    id: int
    kind: str
    pass_id: int
    state: str
    progress: float
    wheels_total: int
    wheels_done: int
    error: str | None
    pipeline_version: str
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None


class JobProgress(BaseModel):
    job_id: int
    pass_id: int
    state: str
    progress: float
    wheels_done: int
    wheels_total: int


class PassSummary(BaseModel):
    id: int
    site: str
    started_at: datetime
    direction: str | None
    speed_kmh: float | None
    fleet: str
    source: Literal["upload", "stream"]
    state: Literal["open", "closed"]
    calibration_version: int
    vehicles: list[str]
    wheels_total: int
    wheels_measured: int
    wheels_not_measured: int
    alarm_count: int
    job: JobProgress | None
    frames_removed_at: datetime | None = Field(
        default=None, description="when frame retention removed the raw frames (results kept)"
    )
    near_limit_count: int = Field(
        default=0, description="wheels near a limit (amber), none in alarm"
    )
    alarm_values: list[str] = Field(
        default_factory=list, description="the values in alarm, e.g. 'V1 axle 1 left: Sh 36.4 mm'"
    )


ItemT = TypeVar("ItemT")


class Page(BaseModel, Generic[ItemT]):
    items: list[ItemT]
    total: int
    offset: int
    limit: int


class Sd10Alias(BaseModel):
    """Responses that carry Sd 10 also under its old name (`flange_thickness_en_mm`)."""

    @computed_field(  # type: ignore[prop-decorator]
        description="deprecated: the old name of flange_thickness_10_mm (Sd 10), the same value"
    )
    @property
    def flange_thickness_en_mm(self) -> float | None:
        value: float | None = getattr(self, "flange_thickness_10_mm")  # noqa: B009
        return value


class MethodResult(Sd10Alias):
    method: str
    status: str
    reason: str | None = Field(
        description="why the wheel was not measured; on a measured result, which flange values "
        "are missing and why, each named ('Sd: …', 'Sd 10: …; qR: …', 'qR: …'), null when none are"
    )
    flange_height_mm: float | None
    flange_thickness_mm: float | None
    flange_thickness_10_mm: float | None
    qr_mm: float | None
    back_to_back_mm: float | None
    tread_hollow_mm: float | None = Field(
        default=None, description="depth below the straight edge at x = 60 and 120 mm"
    )
    flange_angle_deg: float | None = Field(default=None, description="steepest flank angle")
    rim_width_mm: float | None = Field(default=None, description="back face to field face")
    tread_reason: str | None = Field(
        default=None, description="why a tread hollow, flange angle or rim width is missing"
    )
    equivalent_conicity: float | None = Field(
        default=None, description="the axle's EN 15302 equivalent conicity at 3 mm amplitude"
    )
    reference_profile: str | None
    sigma_mean_px: float | None
    sigma_min_px: float | None
    sigma_max_px: float | None
    point_count: int
    quality: dict[str, Any]
    alarms: list[dict[str, Any]]
    pipeline_version: str


class PassWheelRead(BaseModel):
    wheel_id: int
    vehicle_id: str
    axle: int
    side: Side
    state: str
    reason: str | None
    missing_sensors: list[str]
    frames: dict[str, int] = Field(description="frame count per sensor")
    results: list[MethodResult]
    alarm_count: int
    frames_removed_at: datetime | None = Field(
        default=None, description="when frame retention removed the raw frames (results kept)"
    )
    level: Literal["ok", "near", "alarm", "none"] = Field(
        default="none", description="the adaptive result's worst margin level; none unmeasured"
    )
    margins: list[MarginRead] = Field(default_factory=list, description="adaptive, per parameter")
    disposition: DispositionRead | None = Field(default=None, description="None: open")
    method_disagreement: list[Disagreement] = Field(default_factory=list)


class CentresRead(BaseModel):
    """Columnar centre points of one frame: equal-length arrays, ready to draw."""

    method: str
    sensor: Sensor
    seq: int
    width_px: int
    height_px: int
    count: int
    x: list[float]
    y: list[float]
    sigma: list[float]
    strength: list[float]
    nx: list[float]
    ny: list[float]
    rejected_x: list[float] = Field(
        default_factory=list, description="candidates the method rejected [px], where stored"
    )
    rejected_y: list[float] = Field(default_factory=list)


class SigmaMapRead(BaseModel):
    method: str
    sensor: Sensor
    seq: int
    width_px: int
    height_px: int
    sigma_min_px: float
    sigma_max_px: float
    values: list[list[float | None]] = Field(description="σ [px] per pixel row; null outside")


class ProfileRead(BaseModel):
    """Fused profile and reference, columnar [mm], with the parameter construction points."""

    method: str
    reference_profile: str | None
    x_mm: list[float]
    z_mm: list[float]
    outline_x_mm: list[float | None] = Field(
        description="the profile's outline (pipeline.profile.outline): medians of the points "
        "in 0.25 mm steps along the profile, null between pieces apart by a gap [mm]"
    )
    outline_z_mm: list[float | None]
    reference_x_mm: list[float]
    reference_z_mm: list[float]
    construction: dict[str, Any]
    parameters: dict[str, float | None]
    conicity: dict[str, Any] | None = Field(
        default=None,
        description="the axle's Δr(y) (y_mm, delta_r_mm), conicity curve (amplitudes_mm, "
        "conicity), rails and reason: with no y_mm why it was not computed, with y_mm why Δr "
        "covers fewer shifts than searched (amplitudes beyond them have no conicity)",
    )


class TrendPoint(Sd10Alias):
    pass_id: int
    started_at: datetime
    odometer_km: float | None = Field(
        default=None, description="the vehicle's odometer reading at this pass [km]"
    )
    site: str
    method: str
    status: str
    flange_height_mm: float | None
    flange_thickness_mm: float | None
    flange_thickness_10_mm: float | None
    qr_mm: float | None
    back_to_back_mm: float | None
    tread_hollow_mm: float | None = None
    flange_angle_deg: float | None = None
    rim_width_mm: float | None = None
    equivalent_conicity: float | None = None
    alarm_count: int


class WheelTrend(BaseModel):
    wheel_id: int
    vehicle_id: str
    axle: int
    side: Side
    points: list[TrendPoint]
    limits: WheelLimits | None = None
    forecasts: list[TrendForecast] = Field(default_factory=list)


class AuditRead(ORMModel):
    id: int
    at: datetime
    actor: str
    action: str
    target_type: str
    target_id: str | None
    detail: dict[str, Any]


class PassReport(BaseModel):
    """The JSON report of a pass: its summary, the fleet limits and every wheel."""

    model_config = ConfigDict(populate_by_name=True)

    pass_: PassSummary = Field(alias="pass")
    limits: dict[str, dict[str, float]]
    wheels: list[PassWheelRead]


class ParameterRead(BaseModel):
    """A checked wheel parameter: its key in results, label, title and unit."""

    key: str
    label: str
    title: str
    unit: str


class MarginRead(ORMModel):
    """One parameter's distance to its nearest limit: in mm and as a fraction of the band."""

    parameter: str
    value_mm: float
    bound: Literal["min", "max"]
    limit_mm: float
    margin_mm: float
    band_mm: float
    margin_fraction: float
    level: Literal["ok", "near", "alarm"]


class Disagreement(BaseModel):
    """A parameter whose adaptive and Steger values differ by more than the fleet allows."""

    parameter: str
    difference_mm: float = Field(description="adaptive − Steger")
    threshold_mm: float


DispositionKind = Literal["re_profile", "monitor", "false_alarm", "measurement_doubtful", "comment"]


class DispositionCreate(InputModel):
    kind: DispositionKind
    comment: str | None = Field(default=None, max_length=1000)


class DispositionRead(ORMModel):
    id: int
    kind: DispositionKind
    comment: str | None
    actor: str
    created_at: datetime


class WorstWheelRead(BaseModel):
    """One wheel of one pass in the worst-wheels view, at its nearest limit (or the
    filtered parameter's)."""

    pass_id: int
    started_at: datetime
    site: str
    fleet: str
    wheel_id: int
    vehicle_id: str
    axle: int
    side: Side
    wheel_profile: str
    margin: MarginRead
    disposition: DispositionRead | None
    tread_hollow_mm: float | None = Field(
        default=None, description="the same measurement's tread hollow (no limit applies)"
    )
    flange_angle_deg: float | None = Field(default=None, description="its flange angle [°]")
    rim_width_mm: float | None = Field(default=None, description="its rim width")
    equivalent_conicity: float | None = Field(
        default=None, description="its axle's equivalent conicity at 3 mm (EN 15302)"
    )
    values_not_measured: str | None = Field(
        default=None,
        description="the same measurement's values not measured and why, each named ('Sd: …', "
        "'Sd 10: …; qR: …'); a limit it has no value for is not checked; null when none",
    )


class TrendForecast(BaseModel):
    """A robust linear wear fit of one parameter and when it reaches its nearest limit."""

    parameter: str
    per: Literal["day", "1000 km"]
    rate_mm: float = Field(description="wear rate [mm per day or per 1000 km]")
    rate_low_mm: float
    rate_high_mm: float
    points: int
    bound: Literal["min", "max"] | None
    limit_mm: float | None
    near_mm: float | None = Field(description="the amber threshold on the same side [mm]")
    reached_at: datetime | None = Field(description="when the fit reaches the limit (UTC)")
    reached_earliest: datetime | None
    reached_latest: datetime | None
    note: str
    intercept_mm: float | None = Field(
        default=None, description="the fit's value at fit_from (per day) or fit_from_km"
    )
    fit_from: datetime | None = Field(default=None, description="origin of the fit's x (UTC)")
    fit_from_km: float | None = Field(
        default=None, description="odometer origin of the fit's x, per 1000 km only [km]"
    )
    reached_km: float | None = Field(
        default=None, description="odometer reading where the fit reaches the limit [km]"
    )
    reached_km_earliest: float | None = None
    reached_km_latest: float | None = None
    last_km: float | None = Field(default=None, description="odometer at the last pass [km]")


class WheelLimits(BaseModel):
    wheel_profile: str
    limits_mm: dict[str, float]
    near_limit_fraction: float


class VehiclePass(BaseModel):
    pass_id: int
    started_at: datetime
    site: str
    wheels: list[PassWheelRead]


class VehicleHistory(BaseModel):
    vehicle_id: str
    passes: list[VehiclePass] = Field(description="newest first")


class ReferenceRead(ORMModel, Sd10Alias):
    """A handheld-gauge profile of a wheel with its parameters [mm]."""

    id: int
    wheel_id: int
    filename: str
    instrument: str | None
    measured_on: str | None = Field(description="date and time as the file's header gave them")
    measured_at: datetime
    parameter_quality: Literal["fit", "interpolated"] = Field(
        description="fit: the wayside least-squares fits; interpolated: between sparse samples"
    )
    flange_height_mm: float
    flange_thickness_mm: float
    flange_thickness_10_mm: float
    qr_mm: float
    instrument_flange_height_mm: float | None = Field(description="Sh as the file's header gave it")
    instrument_flange_thickness_mm: float | None = Field(
        description="Sd as the file's header gave it (at the instrument's height; MiniProf: 10 mm)"
    )
    instrument_qr_mm: float | None = Field(description="qR as the file's header gave it")
    z_offset_mm: float = Field(description="subtracted from the file's z so that z(70 mm) = 0")
    x_mm: list[float]
    z_mm: list[float]
    created_at: datetime


class ParameterDifference(BaseModel):
    method: str
    parameter: str
    wayside_mm: float | None
    handheld_mm: float
    difference_mm: float | None = Field(description="wayside − handheld")


class ReferenceComparison(BaseModel):
    """One wheel of a pass against its handheld reference nearest in time."""

    pass_id: int
    wheel_id: int
    reference: ReferenceRead | None
    differences: list[ParameterDifference]


class AgreementRow(BaseModel):
    wheel_id: int | None = Field(description="the wheel, over its passes; null: all wheels")
    method: str
    parameter: str
    n: int
    mean_difference_mm: float | None
    mae_mm: float | None
    std_mm: float | None
    max_error_mm: float | None


class AgreementRead(BaseModel):
    """Wayside against handheld over wheels (the paper's Table 2 form) [mm]."""

    pairs: int = Field(description="wheel × pass results paired with a handheld reference")
    rows: list[AgreementRow] = Field(description="over all wheels (the paper's Table 2 form)")
    per_wheel: list[AgreementRow] = Field(description="per wheel (Tables 3–4 form)")
