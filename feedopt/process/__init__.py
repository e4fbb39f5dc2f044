"""process stage of feedopt (see shared/design.md)."""
