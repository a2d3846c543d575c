#pragma once
// The --option NAME=VALUE flags of the commands that open a dataset in a format (`data check`,
// `eval --format`): the format's options by name.
#include <map>
#include <string>
#include <vector>

namespace omnipoint::cli {

// "NAME=VALUE" -> options[NAME] = VALUE; anything else -> std::invalid_argument naming it.
void parse_format_options(const std::vector<std::string>& given,
                          std::map<std::string, std::string>& options);

}  // namespace omnipoint::cli
