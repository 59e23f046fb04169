"""wheelscan database layer: SQLAlchemy 2 typed models, engine/session factory, migrations."""
