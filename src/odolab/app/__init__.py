"""The application layer: one function for each thing a user does.

A face (the CLI, the web notebook's pages and API, the demo) parses its input into a request,
calls one function of this package, and renders the typed result. The rules that decide a number
live here once; when a function chooses for the user, its result says what it chose.

======================================  =============================================  ==========
what a user does                        function                                       result
======================================  =============================================  ==========
select the trials of an analysis        :func:`odolab.app.selection.select`            Selection
Table I and the analysis                :func:`odolab.app.analysis.analyze`            AnalysisResult
a calibration from the notebook         :func:`odolab.app.calibration.calibrate`       CalibrationOutcome
the report                              :func:`odolab.app.report.write_notebook_report` ReportOutcome
the report's numbers (results.json)     :func:`odolab.app.report.report_results`       dict
an export of the notebook's trials      :func:`odolab.app.exports.export_trials`       int
which parameters a log is integrated    :func:`odolab.app.odometry.choose_params`      ParamsChoice
integrate a log                         :func:`odolab.app.odometry.integrate_log`      OdometryOutcome
which model a robot needs               :func:`odolab.app.models.compare_files`        ModelComparison
the slip model from an exploration      :func:`odolab.app.models.slip_comparison`      SlipComparison
the NEES of runs                        :func:`odolab.app.evaluate.nees_of_paths`      NeesOutcome
what ``export mcap`` writes             :func:`odolab.app.exports.mcap_stream`         OdometryStream
old vs new parameters vs a phone IMU    :func:`odolab.app.validate.validate_log`       ValidateOutcome
odometry and a sensor calibrated        :func:`odolab.app.groundtruth.calibrate_sensor_log` SensorOutcome
a marker filmed by a camera             :func:`odolab.app.groundtruth.track_log`       TrackOutcome
a flashing LED's long exposure          :func:`odolab.app.groundtruth.track_photo_log` PhotoTrack
plan, drive and keep a robot run        :func:`odolab.app.robot.plan_run`, ``drive_run``, ``keep_in_notebook`` RobotRun
a virtual board (``robot sim-server``)  :func:`odolab.app.robot.virtual_board`         VirtualBoard
a protocol on the virtual Jaguar        :func:`odolab.app.sim.simulate_protocol`       SimRunOutcome
an exploration on the virtual Jaguar    :func:`odolab.app.sim.simulate_exploration`    ExploreOutcome
a photo of the virtual robot's LED      :func:`odolab.app.sim.simulate_photo`          (path, s)
a trial typed by hand                   :func:`odolab.app.trials.add_trial`            AddedTrial
the demo, end to end                    :func:`odolab.app.demo.run_lab`                LabResult
======================================  =============================================  ==========

Submodules are imported on use (``from odolab.app.calibration import calibrate``), so that a
face that needs one pays for no other. See docs/architecture.md ("The application layer").
"""

from __future__ import annotations

__all__: list[str] = []
