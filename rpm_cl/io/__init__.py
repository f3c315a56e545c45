"""Data in and out: the data model (:mod:`.data`: RadarData, the contract
every reader produces; :mod:`.medium`: the material the data were recorded
in), the file formats and readers, the guards every file passes, and the
image grids and files.  Imports nothing of the rest of the package."""
