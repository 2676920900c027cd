# ctest reads this after the discovered gtest lists (<target>_TESTS): every gtest test gets one
# label and that label's timeout, by its name, whatever executable it is in. The first pattern that
# matches wins; a test no pattern matches is a unit test, so a new slow test fails on the unit
# timeout until it is listed here. The shell tests (cli.*) and viz.xvfb are labelled where they are
# added, in tests/CMakeLists.txt.
#   unit     functions, parsing, single steps, short checks          make test-fast
#   physics  simulated seconds of a controlled system and its outcome
#   viz      rendering: the viewer window and the offscreen recorder
#   cli      the stance binary end to end (tests/cli/*.sh)            make test-fast
set(stance_timeout_unit 60)
set(stance_timeout_physics 600)
set(stance_timeout_viz 600)

set(stance_label_patterns
  viz "^(ViewerTest|RecorderTest|SceneViewTest|TrackVideoTest)\\."
  physics "^(BipedStand|BipedSkateboard|LqrBalance|SimbiconWalk|SimbiconGaits|Simbicon3d|SimbiconCharacter)\\."
  physics "^LqrTwoFeet\\.(Humanoid|Atlas|PitchAnkleRobot)"
  physics "^SimbiconDart\\.Walks"
  physics "^(SimbiconHumanoid|SimbiconFullbody1|SimbiconSpine|SimbiconSteps)\\."
  physics "^SimbiconPitchAnkles\\.Walks"
  physics "^StandPoseAuto\\.(Humanoid|Atlas|SideLoaded)"
  physics "^SimbiconAtlasPitchAnkles\\..*Walks"
  physics "^SlopeWalker\\.(Walks|LockedKnees)"
  physics "^StablePd\\.StandsWherePlainPdDiverges$"
  physics "^DartEngine\\.(BipedFallsAndRestsOnGround|MjcfPendulumPeriod)"
  physics "^PdHoldScenario\\.HoldsOnMujocoAndDart$"
  physics "^(TorqueLimit|AtlasStand|SimbiconAtlas)\\."
  physics "^PushThreshold\\.BipedStand"
  physics "^MocapTracker\\.(MassWalkTenSeconds|Assisted|CrouchInTheClipIsNoFall)"
  physics "^MocapRetarget\\.(Fullbody1Assisted|HumanoidAssisted)"
  physics "^Tune\\.FindsGainsThatStand"
  physics "^Sweep\\.SameCsvsWhateverTheThreadCount$"
  physics "^EveryType/Registry\\."
  physics "^SimulationBranching\\."
  physics "^SimulationLoop\\.StopsOneSecondAfterAFall"
  physics "^PlannerStanding\\."
  physics "^PlannerTracking\\."
  physics "^PlannerWeakAnkles\\."
  physics "^ExternalForces\\.PlannerKeeps"
  physics "^RobustnessMap\\."
  physics "^ShippedScenario/ScenarioExpectation\\.")

foreach(target IN LISTS STANCE_GTEST_TARGETS)
  foreach(test IN LISTS ${target}_TESTS)
    set(label unit)
    set(patterns ${stance_label_patterns})
    while(patterns)
      list(POP_FRONT patterns candidate pattern)
      if(test MATCHES "${pattern}")
        set(label ${candidate})
        break()
      endif()
    endwhile()
    set_tests_properties("${test}" PROPERTIES LABELS ${label} TIMEOUT ${stance_timeout_${label}})
  endforeach()
endforeach()
