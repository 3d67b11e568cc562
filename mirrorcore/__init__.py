"""mirrorcore: one depth camera and flat mirrors -> a merged, source-labelled 3D cloud (Nguyen,
Huynh & Meunier 2018)."""
from mirrorcore.base.errors import CalibrationError, FileFormatError, MirrorscanError

__all__ = ["MirrorscanError", "CalibrationError", "FileFormatError"]
