%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%
MODULE Cell
  PERS tooldata tGripper:=[TRUE,[[10,0,250],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wTable:=[FALSE,TRUE,"",[[1500,0,700],[0.7071068,0,0,0.7071068]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget p10:=[[400,100,300],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p20:=[[450,-100,
                        350],[0,0.7071068,0.7071068,0],[-1,0,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget path{2}:=[[[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],[[4,5,6],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]];
  PROC main()
    MoveAbsJ jHome\NoEOffs, v1000, fine, tool0;
    MoveJ p10, v1000, z50, tGripper\WObj:=wTable;
    MoveL Offs(p10,0,0,100), v100, fine, tGripper\WObj:=wTable;
    MoveC p20, p10, v100, z10, tGripper\WObj:=wTable;
    TriggL path{2}, v500, gunon, z50, tGripper;
    IF n = 2 MoveL path{1}, v100, fine, tool0;
  ERROR
    RETRY;
  ENDPROC
ENDMODULE
