"""``bolts.pvd``: the time index of a bolted run's bolts files, kept as the frames' are."""

from __future__ import annotations

import dataclasses

import meshio
import numpy as np
import pytest

from dda.io import RunWriter, read_pvd
from dda.io.frame_files import all_frames, read_found_frame
from tests.io.test_io import make_frame

ENDS = np.array([[[0.5, 0.5], [2.0, 1.5]], [[0.1, 0.2], [0.3, -1.0]]])
NONE_IN_PLACE = np.zeros((0, 2, 2))


def bolted(step: int, ends: np.ndarray = ENDS):
    """A frame of a run with [[bolts]] at ``step`` (time step / 10), ``ends`` in place."""
    return dataclasses.replace(make_frame(step=step, time=step / 10), bolts=ends)


def write_bolted_run(folder, steps, **options) -> RunWriter:
    writer = RunWriter(folder, image=False, **options)
    for step in steps:
        writer.add_frame(bolted(step, NONE_IN_PLACE if step == 0 else ENDS + step))
    return writer


def test_a_bolted_run_indexes_every_frame_and_pyvista_reads_it(tmp_path):
    """Bolts installed by a stage after step 0: step 0 lists an empty file, so ParaView
    shows no bolt at t = 0 (not the first bolts of a later time)."""
    import pyvista

    write_bolted_run(tmp_path, (0, 5, 10)).finish(None, status="finished")
    index = read_pvd(tmp_path / "bolts.pvd")
    assert [t for t, _ in index] == [0.0, 0.5, 1.0]
    assert [p.name for _, p in index] == [f"bolts_{s:06d}.vtu" for s in (0, 5, 10)]
    reader = pyvista.get_reader(str(tmp_path / "bolts.pvd"))
    np.testing.assert_allclose(reader.time_values, [0.0, 0.5, 1.0])
    reader.set_active_time_value(0.0)
    assert reader.read()[0].n_points == 0
    reader.set_active_time_value(0.5)
    lines = reader.read()[0]
    assert lines.n_cells == 2 and lines.n_points == 4
    np.testing.assert_allclose(lines.points[:2, :2], ENDS[0] + 5)
    assert len(meshio.read(index[0][1]).points) == 0
    frames = [read_found_frame(found) for found in all_frames(tmp_path)]
    assert frames[0].bolts.shape == (0, 2, 2)
    np.testing.assert_array_equal(frames[2].bolts, ENDS + 10)


def test_a_run_without_bolts_writes_no_bolts_index(tmp_path):
    writer = RunWriter(tmp_path, image=False)
    writer.add_frame(make_frame(step=0))
    writer.finish(None, status="finished")
    assert not (tmp_path / "bolts.pvd").exists()
    assert not list((tmp_path / "frames").glob("bolts_*"))


def test_resume_cuts_the_bolts_index_back_and_extends_it(tmp_path):
    write_bolted_run(tmp_path, range(6)).finish(None, status="interrupted")
    resumed = RunWriter(tmp_path, image=False, resume_step=3)
    resumed.add_frame(bolted(5))
    assert [t for t, _ in read_pvd(tmp_path / "bolts.pvd")] == [0.0, 0.1, 0.2, 0.3, 0.5]
    assert all(path.is_file() for _, path in read_pvd(tmp_path / "bolts.pvd"))
    resumed.finish(None, status="finished")


def test_resume_indexes_the_bolts_of_a_run_written_without_the_index(tmp_path):
    write_bolted_run(tmp_path, (0, 1, 2)).finish(None, status="interrupted")
    (tmp_path / "bolts.pvd").unlink()  # as written before there was a bolts.pvd
    RunWriter(tmp_path, image=False, resume_step=2).finish(None, status="finished")
    assert [t for t, _ in read_pvd(tmp_path / "bolts.pvd")] == [0.0, 0.1, 0.2]


def test_overwrite_by_a_run_without_bolts_removes_the_bolts_index(tmp_path):
    write_bolted_run(tmp_path, (0, 1)).finish(None, status="finished")
    writer = RunWriter(tmp_path, image=False, overwrite=True)
    writer.add_frame(make_frame(step=0))
    writer.finish(None, status="finished")
    assert not (tmp_path / "bolts.pvd").exists()
    assert not list((tmp_path / "frames").glob("bolts_*"))


def test_resume_before_the_first_bolts_file_leaves_no_stale_index(tmp_path):
    writer = RunWriter(tmp_path, image=False)
    writer.add_frame(make_frame(step=0))  # bolts=None: no bolts file
    writer.add_frame(bolted(4))
    writer.finish(None, status="interrupted")
    resumed = RunWriter(tmp_path, image=False, resume_step=0)
    assert not (tmp_path / "bolts.pvd").exists()
    resumed.add_frame(bolted(2))
    assert [t for t, _ in read_pvd(tmp_path / "bolts.pvd")] == [0.2]
    resumed.finish(None, status="finished")


def test_the_bolts_files_carry_each_bolt_s_tension(tmp_path):
    """cases/bolted_block.toml: the bolt's tension in the final frame, in its bolts file
    (cell array ``tension``, for ParaView to colour by) and read back, is the anchor's
    measured force (closed form W (sin 30° − cos 30° tan 20°) = 2447.30 N)."""
    import dda.cases
    from dda.io.vtu import read_frame, write_blocks_vtu, write_bolts_vtu

    result = dda.simulate(dda.cases.folder().joinpath("bolted_block.toml"))
    final = result.final
    measured = result.measurements["anchor.force"][-1]
    assert final.bolt_tensions is not None and len(final.bolt_tensions) == 1
    assert final.bolt_tensions[0] == measured == pytest.approx(2447.30, rel=0.01)
    path = write_bolts_vtu(final, tmp_path / "bolts.vtu")
    assert meshio.read(path).cell_data["tension"][0][0] == measured
    blocks = write_blocks_vtu(final, tmp_path / "blocks.vtu")
    again = read_frame(blocks, bolts_path=path)
    np.testing.assert_array_equal(again.bolt_tensions, final.bolt_tensions)
    np.testing.assert_array_equal(again.bolts, final.bolts)


def test_a_bolt_keeps_its_id_in_every_file_when_another_breaks(tmp_path):
    """cases/bolted_block.toml with a second, weak bolt drawn first: it breaks at once
    (2447 N on a 100 N bolt), and the strong bolt is ``bolt`` 1 (summary["bolt_names"])
    in every frame's file, before and after (it became 0 once it was alone: colouring by
    ``bolt`` in ParaView mixed two bolts)."""
    import tomllib

    import dda.cases
    from dda.io.vtu import read_frame, write_blocks_vtu, write_bolts_vtu

    raw = tomllib.loads(dda.cases.folder().joinpath("bolted_block.toml").read_text())
    weak = dict(raw["bolts"][0], name="weak", capacity=100.0)
    raw["bolts"] = [weak, raw["bolts"][0]]
    raw["analysis"]["save_every"] = 1
    result = dda.simulate(dda.load_scene(raw))
    assert result.summary["bolt_names"] == ["weak", "anchor"]
    first, final = result.frames[0], result.final
    assert first.bolt_ids.tolist() == [0, 1] and final.bolt_ids.tolist() == [1]
    path = write_bolts_vtu(final, tmp_path / "bolts.vtu")
    assert meshio.read(path).cell_data["bolt"][0].tolist() == [1]
    again = read_frame(write_blocks_vtu(final, tmp_path / "blocks.vtu"), bolts_path=path)
    assert again.bolt_ids.tolist() == [1]
