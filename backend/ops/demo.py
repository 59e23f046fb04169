"""The demo `make run` serves: a simulated pass, ingested like an upload, measured on start."""

from __future__ import annotations

import hashlib
import sys
import zipfile
from pathlib import Path

from backend.config import Settings
from backend.services.ingest import existing_upload, store_archive, validate_archive
from backend.services.sites import add_calibration_version, get_or_create_site
from backend.storage.store import BlobStore
from db.engine import make_engine, make_session_factory, upgrade_database
from pipeline.archive.pass_archive import read_pass_archive
from pipeline.simulation.field import FIELD_MODES
from pipeline.simulation.passes import write_synthetic_passes

DEMO_SEED = 2026
DEMO_FIELD = FIELD_MODES["harsh"]
"""The demo pass shows the field: the daylit scene and every field effect."""
DEMO_FRAMES = 3
"""Frames each sensor takes of each wheel, as a station bursting at the wheel does
(`pipeline.simulation.passes.FRAME_SPACING_MM` apart): on field frames three frames per
sensor measure every wheel's Sd where one leaves a third of them without (BENCHMARKS.md,
field section)."""
FIXED_ZIP_TIME = (2026, 1, 1, 0, 0, 0)
"""Member timestamp of the demo zip, so the same simulation gives the same bytes."""


def zip_folder(folder: Path, out: Path) -> Path:
    """Zip a pass folder deterministically (sorted members, fixed times, stored)."""
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as archive:
        for path in sorted(p for p in folder.rglob("*") if p.is_file()):
            info = zipfile.ZipInfo(path.relative_to(folder).as_posix(), FIXED_ZIP_TIME)
            archive.writestr(info, path.read_bytes())
    return out


def demo_archive(settings: Settings, vehicles: int) -> Path:
    """The demo pass as a zip under data/demo, simulated on first use."""
    demo_dir = settings.data_dir / "demo"
    out = demo_dir / f"demo-pass-{vehicles}v-seed{DEMO_SEED}-field-{DEMO_FRAMES}f.zip"
    if out.exists():
        return out
    folder = demo_dir / f"pass-{vehicles}v"
    sys.stderr.write(f"wheelscan demo: simulating a pass of {vehicles} vehicle(s)…\n")
    write_synthetic_passes(
        folder, vehicles=vehicles, seed=DEMO_SEED, frames_per_sensor=DEMO_FRAMES, field=DEMO_FIELD
    )
    (folder / "truth.json").rename(demo_dir / f"truth-{vehicles}v.json")
    return zip_folder(folder, out)


def load_demo(settings: Settings, *, vehicles: int) -> int:
    """Register the simulated station's site and calibration and ingest the demo pass.

    Returns the pass id; its wheels are queued and measured when the server starts (the
    runner resumes queued work on start). Loading twice returns the same pass.
    """
    path = demo_archive(settings, vehicles)
    archive_sha256 = hashlib.sha256(path.read_bytes()).hexdigest()
    engine = make_engine(settings.resolved_database_url)
    try:
        upgrade_database(engine)
        with make_session_factory(engine)() as session:
            found = existing_upload(session, archive_sha256)
            if found is not None:
                return found[0].id
            own = read_pass_archive(path, decode_frames=False)
            if own.calibration is None:
                raise ValueError(f"{path} has no calibration.json; the simulator writes one")
            site = get_or_create_site(session, own.manifest.site)
            add_calibration_version(
                session, site, own.calibration, registered=True, note="simulated station (demo)"
            )
            session.commit()
            archive = validate_archive(session, path, settings)
            train_pass, _job, _ids = store_archive(
                session, BlobStore(settings.frames_dir), archive, archive_sha256, None
            )
            return train_pass.id
    finally:
        engine.dispose()
