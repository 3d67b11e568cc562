"""mirrorscan's browser tool (viser) and command line; a thin layer over mirrorcore."""
