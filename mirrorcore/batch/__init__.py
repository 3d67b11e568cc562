"""Floor 9, batch reconstruction of long recordings: one PLY file per frame and a manifest, on
this machine's cores or a Dask cluster, resumable (a rerun does only the frames missing), safe
(atomic files, workers that die are replaced, a cancel keeps every finished frame).

    job = BatchJob(session, out, method="raw", temporal=2)
    report = run_batch(job, Where(workers=2), progress=print)

    run = BatchRun(BatchJob(session, out)).start()
    run.progress; run.cancel(); run.wait()
"""
from mirrorcore.batch.engine import (BatchProgress, BatchReport, BatchRun, default_frames_per_task,
                                     run_batch)
from mirrorcore.batch.executor import Where
from mirrorcore.batch.frames import FrameContext, read_depth, reconstruct_frames
from mirrorcore.batch.job import BATCH_METHODS, BatchJob, exports_folder
from mirrorcore.batch.manifest import MANIFEST_FILE, FrameRecord, Manifest, OutputFolder

__all__ = ["BATCH_METHODS", "MANIFEST_FILE", "BatchJob", "BatchProgress", "BatchReport", "BatchRun",
           "FrameContext",
           "FrameRecord", "Manifest", "OutputFolder", "Where", "default_frames_per_task",
           "exports_folder",
           "read_depth", "reconstruct_frames", "run_batch"]
