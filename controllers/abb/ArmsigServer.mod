MODULE ArmsigServer
  ! armsig's server for the robot's motion task (T_ROB1), contract version 1.
  !
  ! armsig talks to the controller through Robot Web Services (RWS), which reads and writes
  ! RAPID data but cannot command motion. This module moves the robot for it:
  ! armsig writes a target (armsig_target), a speed (armsig_speed) and then a request number
  ! (armsig_cmd, one more than the last); the module moves there with MoveAbsJ, zone fine,
  ! waits until the arm stands still, records where it stands (armsig_joints) and says which
  ! request it finished (armsig_done) and how (armsig_error). armsig reads joints only while
  ! armsig_done = armsig_cmd and the arm is still where armsig_joints says.
  !
  ! Install: docs/how-to/abb.md. Load this module into T_ROB1 (RobotWare 6 and 7 both read
  ! .mod), set the program pointer to main and start the program in AUTO. If the task has a
  ! main routine of its own already, delete main below and call armsig_serve from yours.
  !
  ! Do not rename the data below: armsig addresses them by name (the names and types are
  ! checked against armsig's driver by a test of armsig's, tests/instruments).

  ! The contract this module fulfils.
  PERS num armsig_version:=1;
  ! Written by armsig: where to go (robot axes in degrees; external axes unused).
  PERS jointtarget armsig_target:=[[0,0,0,0,30,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  ! Written by armsig: the velocity override for its moves, percent (1 to 100).
  PERS num armsig_speed:=10;
  ! Written by armsig: the number of the move it asks for.
  PERS num armsig_cmd:=0;
  ! Written here: the last request finished; the arm stands still.
  PERS num armsig_done:=0;
  ! Written here: 0, or the error of request armsig_done (ERRNO, or 1: speed out of range).
  PERS num armsig_error:=0;
  ! Written here: the joints (degrees) where the arm stood still after request armsig_done.
  PERS dnum armsig_joints{6}:=[0,0,0,0,0,0];

  PROC main()
    armsig_serve;
  ENDPROC

  PROC armsig_serve()
    VAR num request;
    ! A request left from before the program was started from main is dropped: the arm
    ! never moves by surprise to an old target. (A program continued after a stop, without
    ! PP to main, finishes the move it was making.)
    armsig_done:=armsig_cmd;
    armsig_error:=0;
    armsig_record;
    WHILE TRUE DO
      WaitUntil armsig_cmd<>armsig_done\PollRate:=0.01;
      request:=armsig_cmd;
      armsig_error:=0;
      armsig_move;
      armsig_record;
      armsig_done:=request;
    ENDWHILE
  ENDPROC

  PROC armsig_move()
    IF armsig_speed<1 OR armsig_speed>100 THEN
      armsig_error:=1;
      RETURN;
    ENDIF
    VelSet armsig_speed,5000;
    MoveAbsJ armsig_target\NoEOffs,vmax,fine,tool0;
  ERROR
    armsig_error:=ERRNO;
    RETURN;
  ENDPROC

  PROC armsig_record()
    VAR jointtarget now;
    WaitRob\ZeroSpeed;
    now:=CJointT();
    armsig_joints{1}:=NumToDnum(now.robax.rax_1);
    armsig_joints{2}:=NumToDnum(now.robax.rax_2);
    armsig_joints{3}:=NumToDnum(now.robax.rax_3);
    armsig_joints{4}:=NumToDnum(now.robax.rax_4);
    armsig_joints{5}:=NumToDnum(now.robax.rax_5);
    armsig_joints{6}:=NumToDnum(now.robax.rax_6);
  ENDPROC
ENDMODULE
