"""From images to numbered marker tracks: detection, 2D linking, numbering and checks across the
two cameras, and numbered tracks to 3D trajectories.

Bottom to top (a module imports only the ones before it): ``merge`` (two cameras' frames in
stamp order), ``centroid_kernel`` (a spot's iterated centroid, compiled), ``cut_discs`` (the
image model of touching, partly covered markers),
``split`` (touching markers fitted apart), ``covered`` (partly covered markers' centres),
``seen_flux`` (how much of a marker a spot shows), ``streak`` (a smeared marker along its
motion), ``band_pass`` (a spot's chroma over its local background, and how much of a marker
its excess chroma says is seen), ``contrast_faint`` (a faint marker beside a track's
prediction found by its contrast to the window's own sand), ``colour_model``
(the clay's colour axis and the frame's chroma floor), ``detect`` (marker spots in one
image), ``shake`` (each frame's image motion from the view's fixed parts), ``linker`` (one
camera's tracks), ``two_view_kernel`` (two views' linear triangulation, compiled),
``associate`` (the marker grid, epipolar geometry, the markers' 3D positions), ``speed_bound``
(the tool's speed as a bound on each camera's links), ``records``
(settings, numbered frames, counts), ``release`` (the publication delay), ``publish_gate``
(numbered points whose pair's 3D point jumps withheld as they go out), ``trajectories``
(numbered tracks to 3D), ``whole_pass`` and ``joint_fill`` (at the pass's end:
never-numbered tracks numbered by one assignment, then unnumbered spots filled from each
marker's 3D path), ``piece_numbering`` (every unnumbered stretch of a 2D track numbered by one
assignment on how well it continues each marker's path), ``bed_field`` (the bed's
displacement field over the pass: where the sand carried a marker no numbered path places),
``bed_numbering`` (unnumbered stretches numbered by that field, one assignment with a
refusal margin), ``pass_audit`` (then every number
against each marker's smooth 3D path: swaps taken out or renumbered), ``carried_numbers``
(then numbers a track carried over a break withheld unless the other camera confirms them),
``touching_exchange`` (and the numbers of two markers that touched in one camera: kept or
exchanged where the other tells them apart, else withheld), ``path_smoother`` (last, each
numbered image path smoothed as much as the pass's residuals say), ``state`` (the tracker's
state, one record), ``held_line``
(whether two tracks held on each other's epipolar line over their common frames),
``link_guide`` (the
other camera inside the 2D link: links barred off the epipolar line, spots that may hold two
markers), ``track_split`` (a spot two numbered tracks predict split where they and the other
camera place them), ``one_camera``,
``ray_rivals`` (a spot one camera alone shows at the grid fit, left waiting while another
free marker rests near its line of sight), ``numbering``, ``pair_checks``,
``pair_numbering``, ``track_pairs`` (an unnumbered track
decided again by a partner held on its line), ``line_rival`` (whether a spot of the
other camera on a track's epipolar line may be a marker nobody holds), ``grid_elimination``
(a marker one camera sees numbered by elimination at the grid fit), ``coming_out`` (a marker
coming out of the sand mid-pass in one camera, numbered where the bed carried it), ``stereo``
(:class:`~dempath_recon.tracking.stereo.StereoMarkerTracker`, the pipeline, and
``track_bag``).
"""
