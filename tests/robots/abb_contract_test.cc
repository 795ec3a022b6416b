// The contract between the ABB driver and the RAPID module armsig ships: the module in the
// source tree is the one compiled into the virtual controller, it declares exactly the
// persistent data the driver addresses (names, types, array sizes), of the contract version
// the driver speaks, and it does what the driver relies on (MoveAbsJ with zone fine, zero
// speed before recording CJointT, a start from main dropping a pending request).
#include <gtest/gtest.h>

#include <set>

#include "robots/abb_controller.h"
#include "robots/rws_codec.h"
#include "simulation/rapid_module.h"
#include "test_support.h"

namespace armsig::robots {
namespace {

std::string ShippedFile() {
  return testing::ReadText(testing::SourcePath("controllers/abb/ArmsigServer.mod"));
}

TEST(AbbContract, TheVirtualControllerRunsTheShippedModule) {
  EXPECT_EQ(simulation::ShippedAbbModule(), ShippedFile());
}

TEST(AbbContract, TheModuleDeclaresExactlyTheDriversData) {
  const simulation::RapidModule module =
      simulation::ParseRapidModule(ShippedFile(), "controllers/abb/ArmsigServer.mod");
  EXPECT_EQ(module.name, abb_contract::kModule);
  std::set<std::string> contract;
  for (const abb_contract::Symbol& symbol : abb_contract::kAll) {
    contract.insert(symbol.name);
    const simulation::RapidData* d = module.Find(symbol.name);
    ASSERT_NE(d, nullptr) << symbol.name << " is not declared by the module";
    EXPECT_EQ(d->name, symbol.name);  // the same spelling: RWS paths name it
    EXPECT_EQ(d->storage, "PERS") << symbol.name;
    EXPECT_EQ(d->type, symbol.type) << symbol.name;
    EXPECT_EQ(d->elements, symbol.elements) << symbol.name;
  }
  for (const simulation::RapidData& d : module.data) {
    if (d.storage == "PERS") {
      EXPECT_TRUE(contract.count(d.name)) << d.name << " is persistent but not in the contract";
    }
  }
  const simulation::RapidData* version = module.Find("armsig_version");
  ASSERT_NE(version, nullptr);
  EXPECT_EQ(rws::ParseRapidNum(version->initial), abb_contract::kVersion);
  EXPECT_EQ(rws::ParseRapidJointTarget(module.Find("armsig_target")->initial).extax[0], 9e9);
  EXPECT_EQ(rws::ParseRapidArray(module.Find("armsig_joints")->initial).size(), 6u);
  EXPECT_EQ(module.routines,
            (std::vector<std::string>{"main", "armsig_serve", "armsig_move", "armsig_record"}));
}

TEST(AbbContract, TheModuleDoesWhatTheDriverReliesOn) {
  const std::string text = ShippedFile();
  for (const char* step : {"WaitUntil armsig_cmd<>armsig_done", "VelSet armsig_speed",
                           "MoveAbsJ armsig_target\\NoEOffs,vmax,fine,tool0", "WaitRob\\ZeroSpeed",
                           "now:=CJointT();", "armsig_done:=armsig_cmd;", "armsig_error:=ERRNO;",
                           "armsig_done:=request;"}) {
    EXPECT_NE(text.find(step), std::string::npos) << step;
  }
  // Dropping a pending request comes before the loop; recording comes before done.
  EXPECT_LT(text.find("armsig_done:=armsig_cmd;"), text.find("WHILE TRUE DO"));
  EXPECT_LT(text.find("armsig_record;\n      armsig_done:=request;"), std::string::npos);
}

TEST(AbbContract, ModuleReaderNamesTheLineOfWhatItCannotRead) {
  EXPECT_THROW(simulation::ParseRapidModule("PROC main()\nENDPROC\n", "m.mod"), InputError);
  try {
    simulation::ParseRapidModule("MODULE M\n  PERS num a:=1;\n  a:=2\n  ;\nENDMODULE\n", "m.mod");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().file, "m.mod");
  }
  EXPECT_THROW(simulation::ParseRapidModule("MODULE M\n PROC p()\nENDMODULE\n", "m.mod"),
               InputError);
  EXPECT_THROW(simulation::ParseRapidModule("MODULE M\n PERS num a;\n VAR num A;\nENDMODULE\n",
                                            "m.mod"),
               InputError);  // RAPID names are case-insensitive: a second declaration
  const auto m = simulation::ParseRapidModule(
      "MODULE M(SYSMODULE) ! comment; PERS num x:=1;\n"
      "  LOCAL VAR dnum d{3}:=[1,\n     2,3]; ! spans lines\n"
      "  CONST string s:=\"a!b\";\nENDMODULE\n",
      "m.mod");
  ASSERT_EQ(m.data.size(), 2u);
  EXPECT_EQ(m.data[0].elements, 3);
  EXPECT_EQ(m.data[0].line, 2);
  EXPECT_EQ(m.data[1].initial, "\"a!b\"");
}

}  // namespace
}  // namespace armsig::robots
