"""The foundation of handeye: what every other package stands on.

numpy only (scipy where a module says so). Nothing here imports ``classic``,
``sim``, ``learned`` or the front (:mod:`handeye.cli` and the pipeline
modules beside it); ``tests/test_layers.py`` enforces it.

* :mod:`handeye.core.se3`: batched rotations, quaternions ``(x, y, z, w)`` and
  transforms ``T_a_b``;
* :mod:`handeye.core.errors` and :mod:`handeye.core.validation`: the named
  ``ValueError`` subclasses and the checks that raise them;
* :mod:`handeye.core.metrics`: errors in degrees and millimetres;
* :mod:`handeye.core.setups`: eye-to-hand and eye-in-hand by name;
* :mod:`handeye.core.posefile`: CSV/JSON pose files (with KUKA, Fanuc and ABB
  rotation columns, :mod:`handeye.core.robot_angles`);
* ROS files (PyYAML for YAML, ``handeye[ros]``): :mod:`handeye.core.easy_handeye`
  (easy_handeye sample lists and calibrations), :mod:`handeye.core.ros_launch`
  (a static-transform launch file), :mod:`handeye.core.urdf_joint` (a URDF joint),
  :mod:`handeye.core.yamlfile` (YAML with line numbers);
* :mod:`handeye.core.dataset`: the labelled RGB-D dataset format;
* :mod:`handeye.core.synthetic`: hand-eye problems with known truth;
* :mod:`handeye.core.rigid`: the rigid fit of matched points, plain and robust, shared by
  ``classic`` and ``learned``;
* :mod:`handeye.core.conventions`: the conventions page;
* :mod:`handeye.core.optional`: the helper that names the extra to install.
"""
