#include "cli/dataset_options.h"

#include <stdexcept>

namespace omnipoint::cli {

void parse_format_options(const std::vector<std::string>& given,
                          std::map<std::string, std::string>& options) {
  for (const std::string& option : given) {
    const std::size_t at = option.find('=');
    if (at == std::string::npos || at == 0)
      throw std::invalid_argument("--option " + option + ": expected NAME=VALUE");
    options[option.substr(0, at)] = option.substr(at + 1);
  }
}

}  // namespace omnipoint::cli
