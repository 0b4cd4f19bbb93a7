//! Loading site files (site.json + plan PNGs) from disk.
