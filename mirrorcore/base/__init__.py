"""Floor 0, what every other floor uses: the library's errors, atomic files, the memory budget,
bounded JSON reading, progress and cancelling, the colours of sources and heat maps."""
from mirrorcore.base.atomic import new_folder, write_atomic
from mirrorcore.base.budget import (MemoryBudgetError, check_memory, format_bytes, memory_budget,
                                    parse_size, set_memory_budget)
from mirrorcore.base.errors import CalibrationError, Cancelled, FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import finite_number, read_json
from mirrorcore.base.palette import (MAX_MIRRORS, MAX_ORDER, heat_map_colours, source_colours,
                                     source_name)
from mirrorcore.base.progress import Progress, Ratchet, cancel_requested

__all__ = ["CalibrationError", "Cancelled", "FileFormatError", "MAX_MIRRORS", "MAX_ORDER",
           "MemoryBudgetError", "MirrorscanError", "Progress", "Ratchet", "cancel_requested",
           "check_memory", "finite_number", "format_bytes", "heat_map_colours", "memory_budget",
           "new_folder", "parse_size", "read_json", "set_memory_budget", "source_colours",
           "source_name", "write_atomic"]
