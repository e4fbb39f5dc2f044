"""robot stage of feedopt (see shared/design.md)."""
