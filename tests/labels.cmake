# ctest labels, given when ctest reads the discovered tests (TEST_INCLUDE_FILES, after the lists of
# tests the GoogleTest executables report):
#   unit            quick and self-contained: `ctest -L unit` runs in well under a minute
#   scenario        runs the product end to end (the host, the command line, whole simulated scenes)
#   browser         opens a page in headless Chromium as a person would
#   sanitizer-safe  light enough for the AddressSanitizer build (tools/sanitize.sh address runs these)
# A test is in exactly one of the first three.

set(browser "^(LoggedDemo\\.MatchReportShowsTheLobToAPersonOpeningIt|ViewedDemo\\.ThePageShowsTheLobInThreeDimensionsAndInTime|CalibrateCommand\\.FindsASimulatedSensorsPoseAndWritesItIntoTheRobotFile)$")
set(scenario "^(MatchDay|LoggedDemo|ViewedDemo|ViewedLog|LiveView|Logger|HostProcess|FusionPlugins|OniRecording|OpenNI2Device|CalibrateCommand|CalibrateDragCommand|CalibrationAlarm|DetectCommand|FuseCommand|TrajectoryScenario|SimSource|Kinect3dPlugin|FreenectOverFakenect|CalibrateBallColourCommand|TeamPlugin)\\.|^BallDetector\\.(FindsKicksAndShotsAndNothingElse|NoPhantomsInClutter|PeopleRoundTheRobotAreNotBallsAndABallAmongThemIsFound|KicksOfABallWithDarkPanelsOrBesideAnotherKinectsSpecksAreFound)$|^BallColour\\.EachMatchBallIsLearntAndToldFromTheRestOfItsSession$|^ColourCheck\\.(RejectsThePhantomsOfPeopleLampsAndLoudspeakersAndKeepsTheBall|TheDemoRobotsLearntBallIsConfirmedInItsOwnScene|AWhiteBallWithBlackPanelsSmearedInFlightIsNeverRejected)$|^TeamWorlds\\.AMislocalisedKeeperIsDiscountedAndMovesNoWorldBallEvenWhereItAloneSeesTheLob$")
# Minutes under AddressSanitizer (they run in the ordinary build; the kicks with dark panels or
# another Kinect's specks repeat, on twelve whole kicks, what BallDetector.ABallWithDarkPanelsIsFoundAnd
# AnotherKinectMakesNoBall runs there); and the simulated OpenNI2 device with colour, whose frames
# there come slower than a live device's one-second watchdog allows; and the team report's live
# robots, whose fusion falls seconds behind the world's clock there.
set(heavy "^(OpenNI2Device\\.DeliversTheColourStreamPairedByTimeWithTheBallWhereTheDepthPutsIt|LoggedDemo\\..*|TeamPlugin\\.(ARobotWithoutAKinectHoldsTheLobFromItsTeammatesAndOutsidersAreRefused|ThroughALossyDelayingDuplicatingNetworkTheDefenderStillHoldsTheLob|AMislocalisedKeeperIsDiscountedByTheDefenderAndNotUsedThroughALossyNetwork|ThreeRobotsInOneWorldHoldTheLobOnlyTheKeepersKinectSees|TwoRobotsOmniCamerasAlonePlaceAHopInTheAirThroughALossyNetwork|WhatARobotSendsIsPlacedWithTheLatenciesItsFusionLearnt)|LiveView\\..*|CalibrationAlarm\\..*|ViewedDemo\\.(ThePageShowsTheLobInThreeDimensionsAndInTime|ASecondViewerOnTheSamePortIsRefusedNotShared)|Logger\\.AHostKilledMidRunLeavesALogThatOpensWithEveryCommittedBatch|MatchDay\\.(ALogWhoseClocksJumpReplaysInTheHostAndInReplayWithoutAStall|ADiskThatRefusesWritesMidRunIsSaidWhereRecordingResumes|LogsOpenReadOnlyOnAReadOnlyMountAndAsAnotherUserAndNothingIsWrittenBesideThem)|FusionPlugins\\.(TheDemoRobotFusesTheLobFlyingOverItWhileItDrives|TheAlignmentCheckFindsAKinectTurnedOnTheRobot)|TrajectoryScenario\\.GoalkeeperSeesWhereAShotCrossesItsLine|BallDetector\\.(FindsKicksAndShotsAndNothingElse|NoPhantomsInClutter|PeopleRoundTheRobotAreNotBallsAndABallAmongThemIsFound|KicksOfABallWithDarkPanelsOrBesideAnotherKinectsSpecksAreFound)|SceneMap\\.(WorksInTheFieldFrameAndStartsAfreshWhenAPoseAppears|FlagsABallHungInPlaceAsStaticButNeverAFlyingOne)|ColourCheck\\.(RejectsThePhantomsOfPeopleLampsAndLoudspeakersAndKeepsTheBall|TheDemoRobotsLearntBallIsConfirmedInItsOwnScene|AWhiteBallWithBlackPanelsSmearedInFlightIsNeverRejected)|BallColour\\..*|TeamWorlds\\.AMislocalisedKeeperIsDiscountedAndMovesNoWorldBallEvenWhereItAloneSeesTheLob)$")

foreach(test IN LISTS framework_tests_TESTS kinect3d_tests_TESTS fusion_tests_TESTS scene_map_tests_TESTS team_tests_TESTS)
  # ctest -j starts the costliest first: the long scenario and browser tests start at once and the
  # quick unit tests fill the gaps, so that no long test starts last and runs alone (on a clean build,
  # before ctest has timed any).
  set(cost 1)
  if(test MATCHES "${browser}")
    set(labels browser)
  elseif(test MATCHES "${scenario}")
    set(labels scenario)
  else()
    set(labels unit)
    set(cost 0)
  endif()
  if(NOT test MATCHES "${heavy}")
    list(APPEND labels sanitizer-safe)
  endif()
  set_tests_properties("${test}" PROPERTIES LABELS "${labels}" COST ${cost})
endforeach()
