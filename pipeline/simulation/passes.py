"""Pass simulator: a train of wheelsets rolling over the simulated station, with ground truth.

A `Train` fixes every wheel (profile, wear, surface) and axle (back-to-back, radius) from a
seed; each simulated pass of it draws new wheelset offsets and yaw, trigger jitter, lighting,
speckle, specular spots, stray light and sensor noise, renders every frame physically
(`pipeline.simulation.render`, `pipeline.simulation.frame_render`) and returns the
`wheelscan-pass/1` content and the truth read off the true wheel geometry.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

from pipeline.archive.manifest import PassManifest, WheelEntry
from pipeline.archive.pass_archive import write_pass_archive
from pipeline.calibration.geometry import camera_centre_track
from pipeline.calibration.model import SENSOR_NAMES
from pipeline.profile.flange import FlangeParameters
from pipeline.profile.reference import load_reference_profile
from pipeline.profile.tread import outline_tread_values
from pipeline.profile.wheelset import ContactError, outline_conicity
from pipeline.simulation.field import (
    FieldEffects,
    add_spots_on_stripe,
    bloom,
    cut_at_flange,
    ghost,
    glare,
    long_part,
    shiny_bands,
    skew,
    stripe_texture,
)
from pipeline.simulation.frame_render import (
    Appearance,
    add_specular_spots,
    add_stray_light,
    draw_stripe,
    expose,
    pass_appearance,
    stripe_peaks,
    wheel_appearance,
)
from pipeline.simulation.render import WheelPose, plate_section, wheel_section
from pipeline.simulation.scene import (
    draw_edges,
    plate_surface,
    rail_surfaces,
    render_scene,
    scene_edges,
    scene_grey,
    wheel_surfaces,
)
from pipeline.simulation.station import NOMINAL_BACK_TO_BACK_MM, Station, build_station
from pipeline.simulation.wheel import Wear, WheelProfile, wheel_profile

AXLES_PER_VEHICLE = 4
TRUTH_NAME = "truth.json"
SPEED_KMH = 5.0
"""The paper passed its train 9 times at 5 km/h."""
FRAME_SPACING_MM = 7.0
"""Travel of the wheel between the frames a sensor takes of it [mm]: a burst at 200 frames/s
triggered by the wheel at 5 km/h (1.39 m/s). Far enough apart that each frame sees its own
patch of the wheel's surface: the reflectance texture's correlation of 3–15 px is 0.7–3.3 mm
along the track (4.5 px/mm there at the tread; correlation < 0.03 beyond it), so the
simulator draws it anew per frame (`field.stripe_texture`); near enough that the laser plane
still cuts the wheel through its axis: a section a mm off the axis reads the flange
a²·(1/r_tread − 1/r_tip)/2 higher, at most 0.006 mm at the 3 frames' ±7 mm plus the
trigger's ±3 mm (docs/simulator.md, "Frames per wheel")."""


@dataclass(frozen=True, slots=True, eq=False)
class SimWheel:
    """One simulated wheel: identity, true outline and surface."""

    vehicle_id: str
    axle: int
    side: str
    profile: WheelProfile
    appearance: Appearance
    back_to_back_mm: float
    radius_mm: float
    wear: Wear
    reference: str
    """Name of the reference profile the wheel was worn from (LMA, S1002)."""


@dataclass(frozen=True, slots=True, eq=False)
class Train:
    """The wheels of a simulated train, in train order (left then right per axle)."""

    vehicles: tuple[str, ...]
    wheels: tuple[SimWheel, ...]


@dataclass(frozen=True, slots=True, eq=False)
class SimulatedPass:
    """One rendered pass: manifest, frames (archive path → image) and per-wheel truth."""

    manifest: PassManifest
    frames: dict[str, np.ndarray]
    truth: dict


def build_train(
    vehicles: int, rng: np.random.Generator, *, axles_per_vehicle: int = AXLES_PER_VEHICLE
) -> Train:
    """Draw a train: LMA wheels (S1002 on every second vehicle) with random wear.

    Parameters
    ----------
    vehicles : int
        Number of vehicles, ≥ 1.
    rng : numpy.random.Generator
    axles_per_vehicle : int
        Axles per vehicle (4 for a bogie vehicle; fewer keeps tests small).
    """
    if vehicles < 1 or axles_per_vehicle < 1:
        raise ValueError(
            f"vehicles and axles_per_vehicle must be ≥ 1, got {vehicles}, {axles_per_vehicle}"
        )
    references = {name: load_reference_profile(name) for name in ("LMA", "S1002")}
    ids = tuple(f"V{v + 1:03d}" for v in range(vehicles))
    wheels = []
    for v, vehicle_id in enumerate(ids):
        family = "S1002" if v % 2 else "LMA"
        reference = references[family]
        for axle in range(1, axles_per_vehicle + 1):
            back_to_back = NOMINAL_BACK_TO_BACK_MM[family] + rng.uniform(-1.5, 1.5)
            radius = rng.uniform(400.0, 420.0)
            for side in ("left", "right"):
                wear = Wear(
                    flange_height_change_mm=rng.uniform(-0.5, 1.5),
                    flange_thinning_mm=rng.uniform(0.0, 2.5),
                    hollow_depth_mm=rng.uniform(0.0, 1.0),
                )
                profile = wheel_profile(reference, wear)
                appearance = wheel_appearance(profile, rng)
                wheels.append(
                    SimWheel(
                        vehicle_id,
                        axle,
                        side,
                        profile,
                        appearance,
                        back_to_back,
                        radius,
                        wear,
                        family,
                    )  # fmt: skip
                )
    return Train(vehicles=ids, wheels=tuple(wheels))


MAX_FLANGE_THINNING_MM = 4.0
"""Most flank wear the wheel model takes (`wheel_profile`)."""


def wear_train(train: Train, flange_thinning_mm: float) -> Train:
    """The same train after more flank wear: every wheel's flange `flange_thinning_mm`
    thinner (its total capped at the model's 4 mm), the surface following the outline.

    Parameters
    ----------
    train : Train
    flange_thinning_mm : float
        Added flank wear [mm], ≥ 0.

    Returns
    -------
    Train
        The worn train (identity, axles and surfaces as before).

    Notes
    -----
    An LMA wheel thinned beyond some 2.5 mm in all may find no rail contact in the truth's
    conicity (`outline_conicity` raises ContactError; seed 21's V001 right at 2.8 mm): its
    truth row then has no conicity.
    """
    if not flange_thinning_mm >= 0:
        raise ValueError(f"flange_thinning_mm must be ≥ 0, got {flange_thinning_mm}")
    wheels = []
    for wheel in train.wheels:
        thinning = min(wheel.wear.flange_thinning_mm + flange_thinning_mm, MAX_FLANGE_THINNING_MM)
        wear = replace(wheel.wear, flange_thinning_mm=thinning)
        profile = wheel_profile(load_reference_profile(wheel.reference), wear)
        # the surface, one value per outline point, moves with the outline's arc fraction
        old = np.linspace(0.0, 1.0, wheel.profile.x_mm.size)
        new = np.linspace(0.0, 1.0, profile.x_mm.size)
        appearance = Appearance(
            reflectivity=np.interp(new, old, wheel.appearance.reflectivity),
            scatter_mm=np.interp(new, old, wheel.appearance.scatter_mm),
        )
        wheels.append(replace(wheel, profile=profile, appearance=appearance, wear=wear))
    return Train(vehicles=train.vehicles, wheels=tuple(wheels))


def _pose(wheel: SimWheel, offset_mm: float, yaw_rad: float, along_mm: float) -> WheelPose:
    return WheelPose(
        centre_track_mm=(offset_mm, along_mm, wheel.radius_mm),
        axle_direction=(float(np.cos(yaw_rad)), float(np.sin(yaw_rad)), 0.0),
        side_sign=1 if wheel.side == "right" else -1,
        back_face_axial_mm=wheel.back_to_back_mm / 2,
        radius_mm=wheel.radius_mm,
    )


def _render_frame(
    station: Station,
    name: str,
    wheel: SimWheel,
    pose: WheelPose,
    rng: np.random.Generator,
    field: FieldEffects | None,
) -> np.ndarray:
    sensor = station.calibration.sensor(name)
    laser = station.laser_origin(name)
    # The frame draws only from children of the pass's generator (spawning takes no draw
    # from it), each field effect and the sensor noise from its own: switching an effect
    # off changes that effect's pixels alone, in this frame and in every later one.
    rng, noise, *children = rng.spawn(2 + len(FieldEffects.names()))
    streams = dict(zip(FieldEffects.names(), children, strict=True))
    on = dict.fromkeys(FieldEffects.names(), False) if field is None else asdict(field)
    appearance = pass_appearance(wheel.appearance, rng)
    samples = wheel_section(wheel.profile, pose, sensor, laser, scatter_mm=appearance.scatter_mm)
    if on["flange_cut"] and name.endswith("outer"):
        samples = cut_at_flange(wheel.profile, samples, streams["flange_cut"])
    shape = (sensor.image_height_px, sensor.image_width_px)
    image = np.zeros(shape, np.float32)
    reflectivity = appearance.reflectivity[samples.outline_index]
    if on["shiny_bands"]:
        factor, band = shiny_bands(wheel.profile, samples, streams["shiny_bands"])
        reflectivity = reflectivity * factor
    peaks = stripe_peaks(samples, reflectivity)
    alpha = None
    if on["asymmetry"]:
        alpha = skew(wheel.profile, samples, pose, sensor, streams["asymmetry"])
    draw_stripe(image, samples, peaks, skew=alpha)
    reflected = ghost(wheel.profile, samples, peaks, streams["ghost"]) if on["ghost"] else None
    if reflected is not None:
        draw_stripe(image, *reflected)
    if on["texture"]:
        image *= stripe_texture(shape, streams["texture"])
    if on["shiny_bands"]:
        draw_stripe(image, *glare(samples, band, streams["shiny_bands"]))
    top_x = wheel.profile.x_mm[np.argmax(wheel.profile.z_mm)]
    on_flange = np.abs(wheel.profile.x_mm[samples.outline_index] - top_x) < 12.0
    add_specular_spots(image, samples, on_flange, rng)
    if on["spots"]:
        add_spots_on_stripe(image, samples, streams["spots"])
    surfaces = []
    if name.endswith("outer"):
        plate_x = pose.side_sign * (pose.back_face_axial_mm + 135.0 + rng.uniform(25.0, 45.0))
        plate_x += pose.centre_track_mm[0]
        z_range = (-30.0, 250.0) if on["long_part_stripe"] else (20.0, 90.0)
        plate = plate_section(sensor, laser, plate_x_mm=plate_x, z_range_mm=z_range, scatter_mm=0.5)
        if on["long_part_stripe"]:
            plate = long_part(plate, samples, streams["long_part_stripe"])
        draw_stripe(image, plate, stripe_peaks(plate, np.full(plate.width_px.size, 0.5)))
        facing = float(np.sign(camera_centre_track(sensor)[0] - plate_x))
        surfaces.append(plate_surface(plate_x, (-30.0, 250.0), facing))
    if on["scene"]:
        surfaces += [*wheel_surfaces(wheel.profile, pose), *rail_surfaces(pose.side_sign)]
        _add_scene(image, surfaces, wheel, pose, sensor, streams["scene"])
    add_stray_light(image, rng)
    if on["blooming"]:
        bloom(image)
    return expose(image, sensor.bit_depth, noise)


def _add_scene(image, surfaces, wheel: SimWheel, pose: WheelPose, sensor, rng) -> None:
    """The daylit scene and its bright corners under the stripe, in place."""
    sky = np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), 1.0])
    shade, distance = render_scene(surfaces, sensor, sky / np.linalg.norm(sky))
    image += scene_grey(shade, rng)
    draw_edges(image, scene_edges(wheel.profile, pose), distance, sensor, rng)


def _truth_row(wheel: SimWheel) -> dict:
    truth: FlangeParameters = wheel.profile.truth
    return {
        "vehicle_id": wheel.vehicle_id,
        "axle": wheel.axle,
        "side": wheel.side,
        "profile": wheel.profile.name,
        "flange_height_mm": truth.flange_height_mm,
        "flange_thickness_mm": truth.flange_thickness_mm,
        "flange_thickness_10_mm": truth.flange_thickness_10_mm,
        "qr_mm": truth.qr_mm,
        "back_to_back_mm": wheel.back_to_back_mm,
        **outline_tread_values(wheel.profile.x_mm, wheel.profile.z_mm, truth.flange_height_mm),
    }


def _truth_rows(train: Train) -> list[dict]:
    """Per-wheel truth, each row with its axle's true equivalent conicity at 3 mm (None
    where the outlines find no contact with the rails: a flange worn thin, see `wear_train`)."""
    rows = [_truth_row(w) for w in train.wheels]
    for left, right, row_left, row_right in zip(
        train.wheels[::2], train.wheels[1::2], rows[::2], rows[1::2], strict=True
    ):
        try:
            conicity: float | None = outline_conicity(
                left.profile.x_mm,
                left.profile.z_mm,
                right.profile.x_mm,
                right.profile.z_mm,
                left.back_to_back_mm,
                left.radius_mm,
            )
        except ContactError:
            conicity = None
        row_left["conicity_3mm"] = row_right["conicity_3mm"] = conicity
    return rows


def simulate_pass(
    train: Train,
    station: Station,
    rng: np.random.Generator,
    *,
    started_at: datetime,
    frames_per_sensor: int = 1,
    site: str = "sim-station",
    field: FieldEffects | None = None,
) -> SimulatedPass:
    """Render one pass of `train` over `station`.

    Parameters
    ----------
    train : Train
    station : Station
    rng : numpy.random.Generator
        Draws this pass's offsets, yaw, trigger jitter, lighting and noise.
    started_at : datetime
        Timezone-aware start time written to the manifest.
    frames_per_sensor : int
        Frames each sensor takes of each wheel (`FRAME_SPACING_MM` apart).
    site : str
    field : FieldEffects, optional
        The field effects the frames show; None: the clean stripe on black.

    Returns
    -------
    SimulatedPass
    """
    frames: dict[str, np.ndarray] = {}
    entries = []
    counters = dict.fromkeys(SENSOR_NAMES, 0)
    axle_motion: dict[tuple[str, int], tuple[float, float, float]] = {}
    for wheel in train.wheels:
        key = (wheel.vehicle_id, wheel.axle)
        if key not in axle_motion:
            axle_motion[key] = (
                rng.uniform(-4.0, 4.0),
                np.deg2rad(rng.uniform(-0.15, 0.15)),
                rng.uniform(-3, 3),
            )
        offset, yaw, along = axle_motion[key]
        paths: dict[str, list[str]] = {"inner": [], "outer": []}
        for k in range(frames_per_sensor):
            pose = _pose(
                wheel, offset, yaw, along + FRAME_SPACING_MM * (k - (frames_per_sensor - 1) / 2)
            )
            for position in ("inner", "outer"):
                name = f"{wheel.side}_{position}"
                counters[name] += 1
                path = f"frames/{name}/{counters[name]:06d}.png"
                frames[path] = _render_frame(station, name, wheel, pose, rng, field)
                paths[position].append(path)
        entries.append(
            WheelEntry(
                wheel.vehicle_id,
                wheel.axle,
                wheel.side,
                tuple(paths["inner"]),
                tuple(paths["outer"]),
            )
        )
    manifest = PassManifest(
        site=site,
        started_at=started_at,
        direction="up",
        speed_kmh=SPEED_KMH,
        vehicles=train.vehicles,
        wheels=tuple(entries),
    )
    truth = {
        "field": None if field is None else asdict(field),
        "wheels": _truth_rows(train),
    }
    return SimulatedPass(manifest, frames, truth)


def pass_start_time(index: int) -> datetime:
    """Start time of the index-th simulated pass (fixed, one hour apart)."""
    return datetime(2026, 11, 23, 8, 0, tzinfo=UTC) + timedelta(hours=index)


def synthetic_train(
    vehicles: int, seed: int, *, axles_per_vehicle: int = AXLES_PER_VEHICLE
) -> Train:
    """The train `write_synthetic_passes` draws for `seed` (before any added wear): its
    wheels' true outlines, for comparing measured profiles with them."""
    train_rng = np.random.default_rng(seed).spawn(1)[0]
    return build_train(vehicles, train_rng, axles_per_vehicle=axles_per_vehicle)


def write_synthetic_passes(
    out: str | Path,
    *,
    vehicles: int = 1,
    seed: int = 0,
    repeat: int = 1,
    bit_depth: int = 8,
    axles_per_vehicle: int = AXLES_PER_VEHICLE,
    frames_per_sensor: int = 1,
    field: FieldEffects | None = None,
    flange_wear_per_pass_mm: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
) -> list[Path]:
    """Simulate `repeat` passes of one train and write them as pass folders with truth.

    Each folder holds manifest.json, calibration.json (the station's true calibration),
    frames/ and truth.json. With repeat = 1 the pass is written into `out` itself, otherwise
    into `out/pass-001`, `out/pass-002`, ….

    Parameters
    ----------
    out : str or Path
        Output folder (created).
    vehicles, axles_per_vehicle : int
        Train size.
    seed : int
        Fixes the train and every pass: the same seed gives the same files.
    repeat : int
        Passes of the same train (new offsets, yaw, lighting, speckle and noise each).
    bit_depth : int
        8 or 16.
    frames_per_sensor : int
        Frames per sensor and wheel.
    field : FieldEffects, optional
        Field effects of every frame (`FIELD_MODES["harsh"]`: all); None: clean frames.
    flange_wear_per_pass_mm : float
        Flank wear added between passes [mm]: pass k's flanges are k times this much thinner
        than the first pass's (`wear_train`; a wear trend with truth). 0: the same wheels.
    progress : callable(done, total), optional
        Called after each pass.

    Returns
    -------
    list of Path
        The pass folders.
    """
    if repeat < 1:
        raise ValueError(f"repeat must be ≥ 1, got {repeat}")
    if not flange_wear_per_pass_mm >= 0:
        raise ValueError(f"flange_wear_per_pass_mm must be ≥ 0, got {flange_wear_per_pass_mm}")
    station = build_station(bit_depth=bit_depth)
    _, *pass_rngs = np.random.default_rng(seed).spawn(repeat + 1)
    train = synthetic_train(vehicles, seed, axles_per_vehicle=axles_per_vehicle)
    out = Path(out)
    folders = []
    for index, rng in enumerate(pass_rngs):
        folder = out if repeat == 1 else out / f"pass-{index + 1:03d}"
        worn = train
        if index and flange_wear_per_pass_mm:
            worn = wear_train(train, index * flange_wear_per_pass_mm)
        simulated = simulate_pass(
            worn,
            station,
            rng,
            started_at=pass_start_time(index),
            frames_per_sensor=frames_per_sensor,
            field=field,
        )
        write_pass_archive(
            folder, simulated.manifest, simulated.frames, calibration=station.calibration
        )
        (folder / TRUTH_NAME).write_text(json.dumps(simulated.truth, indent=2) + "\n")
        folders.append(folder)
        if progress is not None:
            progress(index + 1, repeat)
    return folders


def read_truth(folder: str | Path) -> list[dict]:
    """The per-wheel truth rows of a simulated pass folder (`truth.json` "wheels").

    Raises
    ------
    OSError
        When the folder has no readable truth.json.
    ValueError
        When truth.json is not a {"wheels": [...]} document.
    """
    path = Path(folder) / TRUTH_NAME
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from None
    if not isinstance(document, dict) or not isinstance(document.get("wheels"), list):
        raise ValueError(f"{path} must be {{'wheels': [...]}}")
    return document["wheels"]
