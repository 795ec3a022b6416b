// emScon names: ES_Command, ES_ResultStatus, ES_SystemStatusChange and packet type
// names with the operator's advice for the common statuses (EMSCON.md §2, after the
// Leica emScon 3.8 ES_C_API_Def.h enumerations).
#include <string>

#include "instruments/emscon_codec.h"

namespace armsig::instruments::emscon {

namespace {

// --- Names ----------------------------------------------------------------------------

struct Named {
  int32_t value;
  const char* name;
};

std::string Lookup(const Named* table, size_t n, int32_t value, const char* prefix,
                   const char* unknown) {
  for (size_t i = 0; i < n; ++i) {
    if (table[i].value == value) return std::string(prefix) + table[i].name;
  }
  return std::string(unknown) + std::to_string(value);
}

// ES_Command (EMSCON.md §2.1).
constexpr Named kCommands[] = {
    {0, "ExitApplication"},
    {1, "GetSystemStatus"},
    {2, "GetTrackerStatus"},
    {3, "SetTemperatureRange"},
    {4, "GetTemperatureRange"},
    {5, "SetUnits"},
    {6, "GetUnits"},
    {7, "Initialize"},
    {8, "ReleaseMotors"},
    {9, "ActivateCameraView"},
    {10, "Park"},
    {11, "SwitchLaser"},
    {12, "SetStationOrientationParams"},
    {13, "GetStationOrientationParams"},
    {14, "SetTransformationParams"},
    {15, "GetTransformationParams"},
    {16, "SetBoxRegionParams"},
    {17, "GetBoxRegionParams"},
    {18, "SetSphereRegionParams"},
    {19, "GetSphereRegionParams"},
    {20, "SetEnvironmentParams"},
    {21, "GetEnvironmentParams"},
    {22, "SetRefractionParams"},
    {23, "GetRefractionParams"},
    {24, "SetMeasurementMode"},
    {25, "GetMeasurementMode"},
    {26, "SetCoordinateSystemType"},
    {27, "GetCoordinateSystemType"},
    {28, "SetStationaryModeParams"},
    {29, "GetStationaryModeParams"},
    {30, "SetContinuousTimeModeParams"},
    {31, "GetContinuousTimeModeParams"},
    {32, "SetContinuousDistanceModeParams"},
    {33, "GetContinuousDistanceModeParams"},
    {34, "SetSphereCenterModeParams"},
    {35, "GetSphereCenterModeParams"},
    {36, "SetCircleCenterModeParams"},
    {37, "GetCircleCenterModeParams"},
    {38, "SetGridModeParams"},
    {39, "GetGridModeParams"},
    {40, "SetReflector"},
    {41, "GetReflector"},
    {42, "GetReflectors"},
    {43, "SetSearchParams"},
    {44, "GetSearchParams"},
    {45, "SetAdmParams"},
    {46, "GetAdmParams"},
    {47, "SetSystemSettings"},
    {48, "GetSystemSettings"},
    {49, "StartMeasurement"},
    {51, "StartNivelMeasurement"},
    {52, "StopMeasurement"},
    {53, "ChangeFace"},
    {54, "GoBirdBath"},
    {55, "GoPosition"},
    {56, "GoPositionHVD"},
    {57, "PositionRelativeHV"},
    {58, "PointLaser"},
    {59, "PointLaserHVD"},
    {60, "MoveHV"},
    {61, "GoNivelPosition"},
    {62, "GoLastMeasuredPoint"},
    {63, "FindReflector"},
    {64, "Unknown"},
    {65, "LookForTarget"},
    {66, "GetDirection"},
    {67, "CallOrientToGravity"},
    {79, "SetCompensation"},
    {80, "SetStatisticMode"},
    {81, "GetStatisticMode"},
    {85, "GetCompensation"},
    {86, "GetCompensations"},
    {90, "GetTPInfo"},
    {91, "GetNivelInfo"},
    {95, "GoBirdBath2"},
    {98, "GetFace"},
    {120, "SetLongSystemParameter"},
    {121, "GetLongSystemParameter"},
    {122, "GetMeasurementStatusInfo"},
    {123, "GetCompensations2"},
    {125, "SetDoubleSystemParameter"},
    {126, "GetDoubleSystemParameter"},
    {127, "GetObjectTemperature"},
    {130, "ClearCommandQueue"},
    {131, "GetADMInfo2"},
    {132, "GetTrackerInfo"},
    {133, "GetNivelInfo2"},
    {134, "RestoreStartupConditions"},
    {135, "GoAndMeasure"},
    {138, "GetATRInfo"},
    {139, "GetMeteoStationInfo"},
    {140, "GetAT4xxInfo"},
    {142, "GetSystemSoftwareVersion"},
};

// ES_ResultStatus (EMSCON.md §2.2).
constexpr Named kStatuses[] = {
    {0, "AllOK"},
    {1, "ServerBusy"},
    {2, "NotImplemented"},
    {3, "WrongParameter"},
    {4, "WrongParameter1"},
    {5, "WrongParameter2"},
    {6, "WrongParameter3"},
    {7, "WrongParameter4"},
    {8, "WrongParameter5"},
    {9, "WrongParameter6"},
    {10, "WrongParameter7"},
    {11, "Parameter1OutOfRangeOK"},
    {12, "Parameter1OutOfRangeNOK"},
    {13, "Parameter2OutOfRangeOK"},
    {14, "Parameter2OutOfRangeNOK"},
    {15, "Parameter3OutOfRangeOK"},
    {16, "Parameter3OutOfRangeNOK"},
    {17, "Parameter4OutOfRangeOK"},
    {18, "Parameter4OutOfRangeNOK"},
    {19, "Parameter5OutOfRangeOK"},
    {20, "Parameter5OutOfRangeNOK"},
    {21, "Parameter6OutOfRangeOK"},
    {22, "Parameter6OutOfRangeNOK"},
    {23, "WrongCurrentReflector"},
    {24, "NoCircleCenterFound"},
    {25, "NoSphereCenterFound"},
    {26, "NoTPFound"},
    {27, "NoWeathermonitorFound"},
    {28, "NoLastMeasuredPoint"},
    {29, "NoVideoCamera"},
    {30, "NoAdm"},
    {31, "NoNivel"},
    {32, "WrongTPFirmware"},
    {33, "DataBaseNotFound"},
    {34, "LicenseExpired"},
    {35, "UsageConflict"},
    {36, "Unknown"},
    {37, "NoDistanceSet"},
    {38, "NoTrackerConnected"},
    {39, "TrackerNotInitialized"},
    {40, "ModuleNotStarted"},
    {41, "ModuleTimedOut"},
    {42, "ErrorReadingModuleDb"},
    {43, "ErrorWritingModuleDb"},
    {44, "NotInCameraPosition"},
    {45, "TPHasServiceFirmware"},
    {46, "TPExternalControl"},
    {47, "WrongParameter8"},
    {48, "WrongParameter9"},
    {49, "WrongParameter10"},
    {50, "WrongParameter11"},
    {51, "WrongParameter12"},
    {52, "WrongParameter13"},
    {53, "WrongParameter14"},
    {54, "WrongParameter15"},
    {55, "WrongParameter16"},
    {56, "NoSuchCompensation"},
    {57, "MeteoDataOutOfRange"},
    {58, "InCompensationMode"},
    {59, "InternalProcessActive"},
    {60, "NoCopyProtectionDongleFound"},
    {61, "ModuleNotActivated"},
    {62, "ModuleWrongVersion"},
    {63, "DemoDongleExpired"},
    {64, "ParameterImportFromProbeFailed"},
    {65, "ParameterExportToProbeFailed"},
    {66, "TrkCompMeasCameraMismatch"},
    {67, "NoMeasurementCamera"},
    {68, "NoActiveMeasurementCamera"},
    {69, "NoMeasurementCamerasInDb"},
    {70, "NoCameraToTrackerCompSet"},
    {71, "NoCameraToTrackerCompInDb"},
    {72, "ProblemStoringCameraToTrackerFactorySet"},
    {73, "ProblemWithCameraInternalCalibration"},
    {74, "CommunicationWithMeasurementCameraFailed"},
    {75, "NoMeasurementProbe"},
    {76, "NoActiveMeasurementProbe"},
    {77, "NoMeasurementProbesInDb"},
    {78, "NoMeasurementProbeCompSet"},
    {79, "NoMeasurementProbeCompInDb"},
    {80, "ProblemStoringProbeFactorySet"},
    {81, "WrongActiveMeasurementProbeCompInDb"},
    {82, "CommunicationWithMeasurementProbeFailed"},
    {83, "NoMeasurementTip"},
    {84, "NoActiveMeasurementTip"},
    {85, "NoMeasurementTipsInDb"},
    {86, "NoMeasurementTipCompInDb"},
    {87, "NoMeasurementTipCompSet"},
    {88, "ProblemStoringTipAssembly"},
    {89, "ProblemReadingCompensationDb"},
    {90, "NoDataToImport"},
    {91, "ProblemSettingTriggerSource"},
    {92, "6DModeNotAllowed"},
    {93, "Bad6DResult"},
    {94, "NoTemperatureFromWM"},
    {95, "NoPressureFromWM"},
    {96, "NoHumidityFromWM"},
    {97, "6DMeasurementFace2NotAllowed"},
    {98, "InvalidInputData"},
    {99, "NoTriggerBoard"},
    {10001, "NoMeasurementShankCompSet"},
    {10002, "NoValidADMCompensation"},
    {10003, "PressureSensorProblem"},
    {10004, "MeasurementStatusNotReady"},
    {10005, "ADMStartUpBusy"},
    {10006, "InvalidTipAdapter"},
    {10007, "NoAtr"},
    {10008, "NoOVC"},
    {10009, "NoStationaryResult"},
    {10010, "SensorNotLeveled"},
    {10011, "MultiConnectionsNotAllowed"},
    {10012, "SensorNotWarmedUp"},
    {10013, "SensorNotStable"},
    {10014, "SystemNotReadyForMeasurement"},
    {10015, "CommunicationWithSensorFailed"},
    {10016, "No_Sensor_Battery"},
    {10017, "CompensatorNotAllowed"},
    {10018, "WarmedUpStateReached"},
    {10019, "NotLeveledForInitialization"},
    {10020, "ADMHardwareProblem"},
    {10021, "ATRHardwareProblem"},
};

// ES_SystemStatusChange (EMSCON.md §2.3).
constexpr Named kStatusChanges[] = {
    {0, "DistanceSet"},
    {1, "LaserWarmedUp"},
    {2, "EnvironmentParamsChanged"},
    {3, "RefractionParamsChanged"},
    {4, "SearchParamsChanged"},
    {5, "AdmParamsChanged"},
    {6, "UnitsChanged"},
    {7, "ReflectorChanged"},
    {8, "SystemSettingsChanged"},
    {9, "TemperatureRangeChanged"},
    {10, "CameraParamsChanged"},
    {11, "CompensationChanged"},
    {12, "CoordinateSystemTypeChanged"},
    {13, "BoxRegionParamsChanged"},
    {14, "SphereRegionParamsChanged"},
    {15, "StationOrientationParamsChanged"},
    {16, "TransformationParamsChanged"},
    {17, "MeasurementModeChanged"},
    {18, "StationaryModeParamsChanged"},
    {19, "ContinuousTimeModeParamsChanged"},
    {20, "ContinuousDistanceModeParamsChanged"},
    {21, "GridModeParamsChanged"},
    {22, "CircleCenterModeParamsChanged"},
    {23, "SphereCenterModeParamsChanged"},
    {24, "StatisticModeChanged"},
    {25, "MeasStatus_NotReady"},
    {26, "MeasStatus_Busy"},
    {27, "MeasStatus_Ready"},
    {28, "MeasurementCountReached"},
    {29, "TriggerSourceChanged"},
    {30, "IsFace1"},
    {31, "IsFace2"},
    {32, "ExternalControlActive"},
    {33, "ServiceSoftwareActive"},
    {99, "MeasStatus_6DStatusInvalid"},
    {105, "ObjectTemperatureChanged"},
    {151, "InitializationStatusChanged"},
    {152, "TiltSensorStatusChanged"},
    {820, "EmsysFilesImported"},
    {850, "SensorDetected"},
    {851, "SensorDisconnected"},
    {852, "CompensatorStatusChanged"},
    {853, "BatteryStatusChanged"},
    {997, "TPConnectionClosing"},
    {998, "ServerClosing"},
    {999, "ServerStarted"},
};

constexpr Named kTypes[] = {
    {0, "Command"},
    {1, "Error"},
    {2, "SingleMeasResult"},
    {3, "MultiMeasResult"},
    {4, "StationaryProbeMeasResult"},
    {5, "ContinuousProbeMeasResult"},
    {6, "NivelResult"},
    {7, "ReflectorPosResult"},
    {8, "SystemStatusChange"},
    {9, "SingleMeasResult2"},
    {10, "MultiMeasResult2"},
    {11, "ProbePosResult"},
};

}  // namespace

// --- Names ----------------------------------------------------------------------------

std::string CommandName(int32_t command) {
  return Lookup(kCommands, std::size(kCommands), command, "", "command ");
}
std::string StatusName(int32_t status) {
  return Lookup(kStatuses, std::size(kStatuses), status, "ES_RS_", "ES_RS ");
}
std::string StatusAdvice(int32_t status) {
  switch (status) {
    case status::kServerBusy:
      return "the tracker server is busy (another command or another client)";
    case status::kWrongParameter:
      return "the tracker refused a parameter of the command";
    case status::kNoDistanceSet:
      return "no distance: the beam broke or the reflector left it";
    case status::kTrackerNotInitialized:
      return "the tracker is not initialised (initialise it, or power-cycle it)";
    case status::kMeasurementStatusNotReady:
      return "not ready to measure: no reflector in the beam (lock lost), the tracker still "
             "warming up, or a command still running";
    case status::kNoStationaryResult:
      return "no stable stationary result: the reflector moved during the measurement time";
    default:
      return "";
  }
}

std::string StatusChangeName(int32_t change) {
  return Lookup(kStatusChanges, std::size(kStatusChanges), change, "", "status change ");
}
std::string PacketTypeName(int32_t type) {
  return Lookup(kTypes, std::size(kTypes), type, "", "type ");
}

std::string ToString(DecodeError error) {
  switch (error) {
    case DecodeError::kTruncated:
      return "truncated";
    case DecodeError::kBadSize:
      return "bad size";
    case DecodeError::kUnknownType:
      return "unknown type";
    case DecodeError::kBadLength:
      return "bad length";
  }
  return "?";
}

}  // namespace armsig::instruments::emscon
