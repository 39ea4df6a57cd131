"""SQLite run store: one row per simulation, written the moment a run ends."""
