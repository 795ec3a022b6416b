// The manual page and the bash completion, generated from the CLI itself (the one place
// the commands and options are declared), so neither can fall behind the program.
#include "app/manual.h"

#include "app/command.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <set>
#include <string>
#include <vector>

namespace armsig::app {

namespace {

bool Visible(const CLI::App* sub) { return !sub->get_group().empty(); }

std::vector<const CLI::App*> Subcommands(const CLI::App& app) {
  return app.get_subcommands([](const CLI::App* sub) { return Visible(sub); });
}

// --help, and the program's --version flag; `activate --version N` takes a value and is an
// option like any other (the reference and the manual page left it out).
bool IsHelp(const CLI::Option* option) {
  const auto& names = option->get_lnames();
  const bool flag = option->get_items_expected_max() == 0;
  return std::find(names.begin(), names.end(), "help") != names.end() ||
         (flag && std::find(names.begin(), names.end(), "version") != names.end());
}

// Options of `app` itself, without --help (and --version: it is in the synopsis).
std::vector<const CLI::Option*> Options(const CLI::App& app) {
  return app.get_options([](const CLI::Option* option) { return !IsHelp(option); });
}

// roff text: a leading '.' or '\'' would be a request; backslashes and hyphens escaped.
std::string Roff(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '\\') {
      out += "\\e";
    } else if (c == '-') {
      out += "\\-";
    } else {
      out += c;
    }
  }
  if (!out.empty() && (out[0] == '.' || out[0] == '\'')) out = "\\&" + out;
  return out;
}

// The value an option takes, in plain words: N, NUMBER, FILE, DIR, NAME, STORE, TEXT or the
// choices, not CLI11's type strings ("TEXT:FILE", "FLOAT"); "NUMBER,…" for a comma-separated
// list, "TEXT …" for several values.
std::string ValueName(const CLI::Option* option) {
  std::string type = option->get_type_name();
  if (const auto colon = type.rfind(':'); colon != std::string::npos) type = type.substr(colon + 1);
  if (type == "FLOAT") type = "NUMBER";
  if (type == "INT" || type == "UINT") type = "N";
  if (type.empty()) type = "VALUE";
  if (option->get_delimiter() == ',') return type + ",…";
  if (option->get_items_expected_max() > 1) return type + " …";
  return type;
}

std::string OptionNames(const CLI::Option* option) {
  if (option->get_positional()) {  // by its name: FILE, ID, TABLE
    std::string name = option->get_name(true);
    for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return name;
  }
  std::string label;
  for (const auto& s : option->get_snames()) label += (label.empty() ? "-" : ", -") + s;
  for (const auto& l : option->get_lnames()) label += (label.empty() ? "--" : ", --") + l;
  return label;
}

std::string OptionLabel(const CLI::Option* option) {
  std::string label = OptionNames(option);
  if (!option->get_positional() && option->get_expected_min() > 0) label += " " + ValueName(option);
  return label;
}

void ManCommand(const CLI::App& app, const std::string& path, std::string& out) {
  const auto options = Options(app);
  const auto subs = Subcommands(app);
  out += ".SS \"" + Roff(path) + "\"\n" + Roff(app.get_description()) + "\n";
  for (const auto* option : options) {
    out += ".TP\n.B " + Roff(OptionLabel(option)) + "\n";
    std::string text = option->get_description();
    if (option->get_required()) text += " (required)";
    if (!option->get_default_str().empty()) text += " [default: " + option->get_default_str() + "]";
    out += Roff(text) + "\n";
  }
  for (const auto* sub : subs) ManCommand(*sub, path + " " + sub->get_name(), out);
}

void CollectCommands(const CLI::App& app, const std::string& path,
                     std::vector<std::pair<std::string, const CLI::App*>>& out) {
  out.emplace_back(path, &app);
  for (const auto* sub : Subcommands(app)) {
    CollectCommands(*sub, path.empty() ? sub->get_name() : path + " " + sub->get_name(), out);
  }
}

// Markdown text: characters that would start emphasis, a link, a tag or code are escaped,
// and in a table cell the column bar.
std::string MarkdownText(const std::string& text, bool in_table = false) {
  std::string out;
  for (char c : text) {
    if (c == '\\' || c == '*' || c == '_' || c == '`' || c == '<' || c == '[' || c == ']' ||
        (in_table && c == '|')) {
      out += '\\';
    }
    out += c;
  }
  return out;
}

// An inline code span that holds any text (a longer fence when the text has backticks).
std::string Code(const std::string& text) {
  return text.find('`') == std::string::npos ? "`" + text + "`" : "`` " + text + " ``";
}

// GitHub's heading anchor of "armsig robot add": lower case, spaces to hyphens.
std::string Anchor(const std::string& heading) {
  std::string out;
  for (char c : heading) {
    if (c == ' ') {
      out += '-';
    } else if (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') {
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  return out;
}

// "armsig orient --observations TEXT --out FILE [OPTIONS]": the command, its positionals
// and required options, then what may follow.
std::string Synopsis(const CLI::App& app, const std::string& path) {
  std::string line = path;
  if (!Subcommands(app).empty()) return line + " COMMAND …";
  bool optional = false;
  for (const auto* option : Options(app)) {
    if (option->get_positional()) {
      line += " " + (option->get_required() ? OptionNames(option) : "[" + OptionNames(option) + "]");
    } else if (option->get_required()) {
      line += " " + OptionLabel(option);
    } else {
      optional = true;
    }
  }
  return optional ? line + " [OPTIONS]" : line;
}

void MarkdownOption(const CLI::Option* option, std::string& out) {
  std::string text = "- " + Code(OptionLabel(option));
  std::string notes;
  if (option->get_required()) notes += "required";
  text += notes.empty() ? "" : " (" + notes + ")";
  text += " — " + MarkdownText(option->get_description());
  if (!text.empty() && text.back() != '.') text += ".";
  if (const auto& choices = ChoicesOf(option); !choices.empty()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + Code(c);
    text += " One of " + list + ".";
  }
  if (!option->get_default_str().empty() && option->get_expected_min() > 0) {
    text += " Default: " + Code(option->get_default_str()) + ".";
  }
  out += text + "\n";
}

void MarkdownCommand(const CLI::App& app, const std::string& path, std::string& out) {
  out += "\n## " + path + "\n\n" + MarkdownText(app.get_description()) + "\n\n";
  out += "```\n" + Synopsis(app, path) + "\n```\n";
  const auto subs = Subcommands(app);
  if (!subs.empty()) {
    out += "\n";
    for (const auto* sub : subs) {
      const std::string sub_path = path + " " + sub->get_name();
      out += "- [" + Code(sub_path) + "](#" + Anchor(sub_path) + ") — " +
             MarkdownText(sub->get_description()) + "\n";
    }
  }
  const auto options = Options(app);
  if (!options.empty()) {
    out += "\n";
    for (const auto* option : options) MarkdownOption(option, out);
  }
  for (const auto* sub : subs) MarkdownCommand(*sub, path + " " + sub->get_name(), out);
}

}  // namespace

std::string ManPage(const CLI::App& app, const std::string& version, const std::string& date) {
  std::string out;
  out += fmt::format(".TH ARMSIG 1 \"{}\" \"armsig {}\" \"User Commands\"\n", date, version);
  out += ".SH NAME\narmsig \\- measure an industrial robot and fit its arm signature\n";
  out +=
      ".SH SYNOPSIS\n.B armsig\n[\\-\\-db PATH] [\\-q | \\-v | \\-vv] [\\-\\-version] "
      "\\fICOMMAND\\fR ...\n.br\n.B armsig\n\\fICOMMAND\\fR \\-\\-help\n";
  out +=
      ".SH DESCRIPTION\n"
      "armsig measures one industrial robot with external instruments (theodolites, total "
      "stations, laser trackers) and fits its own kinematic error parameters, its arm "
      "signature, after Chen and Chao. Human output goes to stdout, logs and progress to "
      "stderr, machine output behind \\-\\-json.\n";
  out += ".SH GLOBAL OPTIONS\n";
  for (const auto* option : Options(app)) {
    out += ".TP\n.B " + Roff(OptionLabel(option)) + "\n" + Roff(option->get_description()) + "\n";
  }
  out += ".SH COMMANDS\n";
  for (const auto* sub : Subcommands(app)) ManCommand(*sub, "armsig " + sub->get_name(), out);
  out +=
      ".SH EXIT STATUS\n"
      ".TP\n.B 0\nsuccess\n"
      ".TP\n.B 1\nfailure (a fit that did not converge, an instrument that keeps failing, a "
      "paused capture, unreachable targets)\n"
      ".TP\n.B 2\nusage or input error: the message names the file, line, column and what "
      "was expected; nothing is written\n"
      ".TP\n.B 3\na quality gate failed (the active arm signature stays active)\n"
      ".TP\n.B 4\nrecalibrate: drift; a set fitted after the change is stored and active\n"
      ".TP\n.B 5\nrecalibrate: drift suspected, not enough data after the change; nothing "
      "stored\n"
      ".TP\n.B 6\nthe work is stored, but an output that follows it could not be written\n"
      ".TP\n.B 130\nstopped by Ctrl\\-C, SIGTERM or SIGHUP at a safe point; the work is left "
      "resumable (every command)\n";
  out +=
      ".SH ENVIRONMENT\n.TP\n.B ARMSIG_DB\nthe database when \\-\\-db is not given "
      "(else ./armsig.db)\n";
  out +=
      ".SH FILES\n.TP\n.I /usr/share/armsig/models/\nrobot model files (PUMA 760, UR10)\n"
      ".TP\n.I /lib/systemd/system/armsig\\-recalibrate@.service\nthe nightly recalibration "
      "of one robot, with its .timer\n";
  out += ".SH SEE ALSO\nThe README of the armsig sources.\n";
  return out;
}

std::string MarkdownReference(const CLI::App& app) {
  std::string out =
      "<!-- Generated from the program's own command line by `armsig generate markdown`: do not "
      "edit.\n     After changing a command: build/armsig generate markdown > "
      "docs/reference/commands.md -->\n"
      "# Command reference\n\n"
      "Every command of armsig with its options, as the program itself declares them (the "
      "same source as `armsig COMMAND --help` and `man armsig`). What all commands share — "
      "the store, where output goes, logs, signals and exit codes — is in "
      "[the command-line conventions](cli.md); the files they read and write are in "
      "[file formats](file-formats.md).\n\n"
      "```\narmsig [--db STORE] [-q | -v | -vv] [--version] COMMAND …\n"
      "armsig COMMAND --help\n```\n\n"
      "## Global options\n\nAccepted before or after the command name.\n\n";
  for (const auto* option : Options(app)) MarkdownOption(option, out);
  out += "\n## Commands\n\n| command | what it does |\n| --- | --- |\n";
  std::vector<std::pair<std::string, const CLI::App*>> commands;
  CollectCommands(app, "", commands);
  for (const auto& [path, command] : commands) {
    if (path.empty()) continue;
    const std::string full = "armsig " + path;
    out += "| [" + Code(full) + "](#" + Anchor(full) + ") | " +
           MarkdownText(command->get_description(), true) + " |\n";
  }
  for (const auto* sub : Subcommands(app)) MarkdownCommand(*sub, "armsig " + sub->get_name(), out);
  return out;
}

std::string BashCompletion(const CLI::App& app) {
  std::vector<std::pair<std::string, const CLI::App*>> commands;
  CollectCommands(app, "", commands);
  std::string cases;
  for (const auto& [path, command] : commands) {
    std::string words, value_options, choices;
    for (const auto* sub : Subcommands(*command)) words += " " + sub->get_name();
    for (const auto* option : command->get_options()) {
      if (option->get_positional()) continue;
      for (const auto& s : option->get_snames()) words += " -" + s;
      for (const auto& l : option->get_lnames()) {
        words += " --" + l;
        if (option->get_expected_min() > 0) value_options += " --" + l;
        // An option with named choices completes them.
        if (const auto& named = ChoicesOf(option); !named.empty()) {
          std::string list;
          for (const auto& c : named) list += (list.empty() ? "" : " ") + c;
          choices += fmt::format(" [--{}]=\"{}\"", l, list);
        }
      }
    }
    cases += fmt::format(
        "    \"{}\") words=\"{}\"; takes_value=\"{} \"; choices=({}) ;;\n", path,
        words.empty() ? "" : words.substr(1), value_options, choices.empty() ? "" : choices.substr(1));
  }
  // The global options' words, to skip over them (with their values) in the command path.
  std::string global_values;
  for (const auto* option : app.get_options()) {
    if (option->get_expected_min() == 0) continue;
    for (const auto& l : option->get_lnames()) global_values += " --" + l;
  }
  std::set<std::string> names;
  for (const auto& [path, command] : commands) {
    for (const auto* sub : Subcommands(*command)) names.insert(sub->get_name());
  }
  std::string known;
  for (const auto& n : names) known += " " + n;
  return fmt::format(
      R"(# bash completion for armsig (generated by `armsig generate bash-completion`)
_armsig() {{
  local cur prev path="" word i words takes_value
  local -A choices=()
  cur="${{COMP_WORDS[COMP_CWORD]}}"
  prev="${{COMP_WORDS[COMP_CWORD-1]}}"
  local commands=" {} "
  # The command path typed so far: the known command words, in order.
  for ((i = 1; i < COMP_CWORD; i++)); do
    word="${{COMP_WORDS[i]}}"
    case "$word" in
      -*) continue ;;
    esac
    local candidate="${{path:+$path }}$word"
    if [[ "$commands" == *" $word "* ]] && _armsig_known "$candidate"; then
      path="$candidate"
    fi
  done
  _armsig_words "$path"
  local global_values="{} "
  if [[ -n "${{choices[$prev]:-}}" ]]; then
    COMPREPLY=($(compgen -W "${{choices[$prev]}}" -- "$cur"))
    return
  fi
  if [[ "$takes_value$global_values" == *" $prev "* ]]; then
    COMPREPLY=($(compgen -f -- "$cur"))
    return
  fi
  COMPREPLY=($(compgen -W "$words" -- "$cur"))
  if [[ ${{#COMPREPLY[@]}} -eq 0 && "$cur" != -* ]]; then
    COMPREPLY=($(compgen -f -- "$cur"))
  fi
}}
_armsig_known() {{
  _armsig_words "$1"
  [[ -n "$words" ]]
}}
_armsig_words() {{
  words=""
  takes_value=" "
  choices=()
  case "$1" in
{}  esac
}}
complete -o filenames -F _armsig armsig
)",
      known.empty() ? "" : known.substr(1), global_values, cases);
}

}  // namespace armsig::app
