"""Safe file input and output: inputs checked and read within a size limit (:mod:`.reading`), output
locations checked before long work, outputs that would overwrite each other or an input refused
(:mod:`.locations`), the manifest of what bipedsim wrote in an output folder, the only files it replaces
or deletes unasked (:mod:`.manifest`), atomic writes that respect the umask and leave no temporary file
behind (:mod:`.writing`), terminal progress bars (:mod:`.progress`), provenance, what made an output
(:mod:`.provenance`), and one line for an operating-system error (:mod:`.os_errors`).

Imported by the command line at start-up: the heavy libraries (numpy, tqdm, MuJoCo, SciPy) are imported
inside the functions that need them, so ``--help`` stays quick.
"""

from __future__ import annotations

from bipedsim.files.locations import (
    NamedPath,
    check_distinct_paths,
    check_output_file,
    folder_files,
    prepare_output_dir,
)
from bipedsim.files.manifest import (
    MANIFEST_FILE,
    MANIFEST_FORMAT,
    MANIFEST_LIMIT_BYTES,
    MANIFEST_VERSION,
    OutputFolder,
    file_digest,
)
from bipedsim.files.os_errors import WRITE_ERRNOS, describe_os_error, os_reason
from bipedsim.files.progress import FALLBACK_SIZE, progress_bar, stderr_size
from bipedsim.files.provenance import versions
from bipedsim.files.reading import (
    INPUT_LIMITS_MB,
    READ_CHUNK_BYTES,
    check_input_file,
    decode_text,
    input_limit_bytes,
    json_kind,
    read_input_bytes,
    read_input_text,
)
from bipedsim.files.writing import (
    NEW_FILE_MODE,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    atomic_writer,
    process_umask,
    save_figure,
)

__all__ = [
    "FALLBACK_SIZE",
    "INPUT_LIMITS_MB",
    "MANIFEST_FILE",
    "MANIFEST_FORMAT",
    "MANIFEST_LIMIT_BYTES",
    "MANIFEST_VERSION",
    "NEW_FILE_MODE",
    "READ_CHUNK_BYTES",
    "WRITE_ERRNOS",
    "NamedPath",
    "OutputFolder",
    "atomic_write_bytes",
    "atomic_write_json",
    "atomic_write_text",
    "atomic_writer",
    "check_distinct_paths",
    "check_input_file",
    "check_output_file",
    "decode_text",
    "describe_os_error",
    "file_digest",
    "folder_files",
    "input_limit_bytes",
    "json_kind",
    "os_reason",
    "prepare_output_dir",
    "process_umask",
    "progress_bar",
    "read_input_bytes",
    "read_input_text",
    "save_figure",
    "stderr_size",
    "versions",
]
