"""The constraint kinds, one module each (`base.Kind` is the interface they implement)."""
