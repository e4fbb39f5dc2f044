"""geometry stage of feedopt (see shared/design.md)."""
