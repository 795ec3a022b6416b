// The parameter spec of `armsig calibrate --params` (estimation.h: ParseParameterSpec).
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "calibration/estimation.h"
#include "calibration/terms.h"
#include "core/text.h"

namespace armsig::calibration {

std::vector<int> ParseParameterSpec(const RobotModel& model, const std::string& spec) {
  std::set<int> chosen;
  const auto names = model.ParameterNames();
  std::stringstream stream(spec);
  std::string token;
  bool any = false;
  while (std::getline(stream, token, ',')) {
    token.erase(0, token.find_first_not_of(" \t"));
    token.erase(token.find_last_not_of(" \t") + 1);
    if (token.empty()) continue;
    any = true;
    if (token == "geometric") {
      for (int i = 0; i < model.num_geometric(); ++i) {
        if (!model.IsHeld(i)) chosen.insert(i);
      }
    } else if (token == "all") {
      for (int i = 0; i < model.num_parameters(); ++i) {
        if (!model.IsHeld(i)) chosen.insert(i);
      }
    } else if (const auto family = TermFamilyFromName(token)) {
      bool found = false;
      for (size_t k = 0; k < model.nongeometric.size(); ++k) {
        if (model.nongeometric[k].family != *family) continue;
        chosen.insert(model.num_geometric() + static_cast<int>(k));
        found = true;
      }
      if (!found) {
        throw std::invalid_argument("the model has no " + token +
                                    " terms (generate them: 'generated_terms: [" + token +
                                    "]' in the model file)");
      }
    } else if (int index = model.IndexOf(token); index >= 0) {
      if (model.IsHeld(index)) {
        throw std::invalid_argument(
            Quoted(token) +
            " is held at zero with 'tool_mounting: known' (the target's place on "
            "the flange is known: " +
            (index == model.tool_index() - 1
                 ? std::string("a turn about the last joint and one about the lever are one "
                               "unknown on a position; the flange turn alpha, beta takes the rest")
                 : std::string("a shift there is the flange's turn alpha, beta")) +
            "); leave it out, or use 'tool_mounting: fitted'");
      }
      chosen.insert(index);
    } else {
      std::vector<std::string> words = {"geometric", "all", "compliance", "harmonics"};
      words.insert(words.end(), names.begin(), names.end());
      const auto nearest = NearestKey(token, words);
      std::string terms;
      for (size_t i = model.num_geometric(); i < names.size(); ++i)
        terms += (terms.empty() ? "" : ", ") + names[i];
      throw std::invalid_argument(
          "unknown parameter " + Quoted(token) +
          (nearest ? " (did you mean " + Quoted(*nearest) + "?)" : std::string()) +
          "; expected geometric, all, compliance, harmonics or parameter names (a1 … c" +
          std::to_string(model.num_joints() + 1) +
          (terms.empty() ? std::string() : ", " + terms) + ")");
    }
  }
  if (!any) throw std::invalid_argument("empty parameter list");
  return {chosen.begin(), chosen.end()};
}

}  // namespace armsig::calibration
