// A small HTML writer whose text is escaped by construction. A page is an `Html` value,
// and an Html value is made only of
//   - string literals in the source (`Html("<td>")`: markup the programmer wrote),
//   - `Html::Text(s)`: any text, escaped (& < > " ' become entities), and
//   - `Html::Trusted(s)`: markup built by the program itself (a base64 image, a style
//     sheet), marked as such where it is made;
// and `HtmlFormat("<td>{}</td>", value)` takes a literal format string and escapes every
// argument that is text, inserts arguments that are Html as they are, and formats numbers.
// A std::string does not convert to Html, so a name from a model file or the database
// cannot reach the page unescaped by forgetting a call: it does not compile.
#pragma once

#include <fmt/format.h>

#include <cstddef>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "core/text.h"

namespace armsig::report {

class Html {
 public:
  Html() = default;
  // A string literal written in the source is markup.
  template <std::size_t N>
  Html(const char (&literal)[N]) : markup_(literal, N - 1) {}  // NOLINT: implicit on purpose

  static Html Text(std::string_view text) { return Html(EscapeMarkup(text), 0); }
  static Html Trusted(std::string markup) { return Html(std::move(markup), 0); }

  Html& operator+=(const Html& other) {
    markup_ += other.markup_;
    return *this;
  }
  friend Html operator+(Html a, const Html& b) { return a += b; }

  bool empty() const { return markup_.empty(); }
  const std::string& str() const { return markup_; }

 private:
  Html(std::string markup, int) : markup_(std::move(markup)) {}
  std::string markup_;
};

namespace html_detail {

template <typename T>
using Plain = std::remove_cvref_t<T>;

template <typename T>
constexpr bool kIsText =
    std::is_convertible_v<const T&, std::string_view> && !std::is_same_v<Plain<T>, Html>;

// What HtmlFormat hands to fmt for an argument: Html as it is, text escaped, numbers
// (and other formattable values without text) as they are.
template <typename T>
decltype(auto) Argument(const T& value) {
  if constexpr (std::is_same_v<Plain<T>, Html>) {
    return std::string_view(value.str());
  } else if constexpr (kIsText<T>) {
    return EscapeMarkup(std::string_view(value));
  } else {
    static_assert(std::is_arithmetic_v<Plain<T>>,
                  "HtmlFormat: pass text, numbers or Html (escape other values explicitly)");
    return value;
  }
}

template <typename T>
using ArgumentType = decltype(Argument(std::declval<const T&>()));

}  // namespace html_detail

template <typename... Args>
Html HtmlFormat(fmt::format_string<html_detail::ArgumentType<Args>...> format,
                const Args&... args) {
  return Html::Trusted(fmt::format(format, html_detail::Argument(args)...));
}

}  // namespace armsig::report
