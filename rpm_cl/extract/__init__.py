"""From range profiles to range points: preprocessing, the k-space and
near-field decompositions, Capon and matched-filter RP extraction, the
echoes' phase, and the medium check of their tracks.  Imports
:mod:`rpm_cl.io` and the shared utilities only."""
