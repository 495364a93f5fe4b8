#include "proto/text_file.h"

#include <fcntl.h>
#include <google/protobuf/io/tokenizer.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace doppel::proto {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;
using google::protobuf::TextFormat;

// Collects the first syntax error with its position (protobuf lines and columns are 0-based).
class FirstError : public google::protobuf::io::ErrorCollector {
 public:
  void AddError(int line, int column, const std::string& message) override {
    if (message_.empty()) {
      message_ = std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " + message;
    }
  }
  void AddWarning(int, int, const std::string&) override {}
  const std::string& message() const { return message_; }

 private:
  std::string message_;
};

std::string position_text(const TextFormat::ParseLocation& where) {
  return std::to_string(where.line + 1) + ":" + std::to_string(where.column + 1);
}

}  // namespace

std::string file_kind(mode_t mode) {
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string TextFile::read(const std::string& path, std::string_view what) {
  const std::string cannot = path + ": cannot read " + std::string(what) + ": ";
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below anyway.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    throw std::runtime_error(cannot + std::strerror(errno));
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    throw std::runtime_error(cannot + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) {
    throw std::runtime_error(cannot + "it is a directory");
  }
  if (!S_ISREG(st.st_mode)) {
    throw std::runtime_error(cannot + "it is " + file_kind(st.st_mode) + ", not a regular file");
  }
  const auto too_big = [&] {
    return std::runtime_error(cannot + "it is larger than " + std::to_string(kMaxBytes / (1024 * 1024)) +
                              " MiB, the limit for text files");
  };
  if (st.st_size > static_cast<off_t>(kMaxBytes)) {
    throw too_big();
  }
  // Reads up to one byte past the limit, in case the file grew since fstat.
  std::string text(static_cast<std::size_t>(st.st_size) + 1, '\0');
  std::size_t have = 0;
  for (;;) {
    if (have == text.size()) {
      if (text.size() > kMaxBytes) throw too_big();
      text.resize(std::min(text.size() * 2, kMaxBytes + 1));
    }
    const ssize_t n = ::read(fd, text.data() + have, text.size() - have);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::runtime_error(cannot + std::strerror(errno));
    if (n == 0) break;
    have += static_cast<std::size_t>(n);
  }
  text.resize(have);
  return text;
}

void TextFile::parse_into(std::unique_ptr<Message> message, std::string_view text, const std::string& path) {
  path_ = path;
  message_ = std::move(message);
  tree_ = std::make_unique<TextFormat::ParseInfoTree>();
  nodes_.clear();
  FirstError errors;
  TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(tree_.get());
  if (!parser.ParseFromString(std::string(text), message_.get())) {
    throw std::runtime_error(path + ":" + errors.message());
  }
  index_locations(*message_, tree_.get(), "1:1");
  check_string_lengths(*message_);
}

void TextFile::check_string_lengths(const Message& message) const {
  const Descriptor* descriptor = message.GetDescriptor();
  const Reflection* reflection = message.GetReflection();
  for (int f = 0; f < descriptor->field_count(); ++f) {
    const FieldDescriptor* field = descriptor->field(f);
    const bool repeated = field->is_repeated();
    const int count = repeated ? reflection->FieldSize(message, field) : (reflection->HasField(message, field) ? 1 : 0);
    for (int i = 0; i < count; ++i) {
      const int index = repeated ? i : -1;
      if (field->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
        check_string_lengths(repeated ? reflection->GetRepeatedMessage(message, field, i)
                                      : reflection->GetMessage(message, field));
      } else if (field->cpp_type() == FieldDescriptor::CPPTYPE_STRING) {
        const bool is_path = field->name() == "file" || field->name() == "package_path" ||
                             field->name() == "argv" || field->name() == "value";  // scenario: commands, parameters
        const std::size_t limit =
            field->name() == "description" ? kMaxDescriptionChars : (is_path ? kMaxPathChars : kMaxNameChars);
        std::string scratch;
        const std::size_t length = (repeated ? reflection->GetRepeatedStringReference(message, field, i, &scratch)
                                             : reflection->GetStringReference(message, field, &scratch))
                                       .size();
        if (length > limit) {
          fail(message, field->name(), index,
               std::to_string(length) + " characters, more than the " + std::to_string(limit) + " allowed");
        }
      }
    }
  }
}

void TextFile::index_locations(const Message& message, const TextFormat::ParseInfoTree* tree, std::string position) {
  nodes_[&message] = Node{tree, std::move(position), nullptr};
  const Descriptor* descriptor = message.GetDescriptor();
  const Reflection* reflection = message.GetReflection();
  for (int f = 0; f < descriptor->field_count(); ++f) {
    const FieldDescriptor* field = descriptor->field(f);
    if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) {
      continue;
    }
    if (field->is_repeated()) {
      for (int i = 0; i < reflection->FieldSize(message, field); ++i) {
        index_locations(reflection->GetRepeatedMessage(message, field, i), tree->GetTreeForNested(field, i),
                        position_text(tree->GetLocation(field, i)));
      }
    } else if (reflection->HasField(message, field)) {
      index_locations(reflection->GetMessage(message, field), tree->GetTreeForNested(field, -1),
                      position_text(tree->GetLocation(field, -1)));
    }
  }
}

void TextFile::alias(const Message& generated, const Message& source) {
  auto node = nodes_.find(&source);
  if (node == nodes_.end()) {
    return;
  }
  Node copy = node->second;
  if (copy.source == nullptr) {
    copy.source = &source;
  }
  nodes_[&generated] = copy;
}

std::string TextFile::location(const Message& message, std::string_view field, int index) const {
  auto node = nodes_.find(&message);
  if (node == nodes_.end()) {
    return path_;
  }
  // An alias reports the field of the same name in the message it stands for.
  const Message& written = node->second.source != nullptr ? *node->second.source : message;
  const FieldDescriptor* descriptor = written.GetDescriptor()->FindFieldByName(std::string(field));
  bool present = descriptor != nullptr &&
                 (descriptor->is_repeated()
                      ? index >= 0 && index < written.GetReflection()->FieldSize(written, descriptor)
                      : index < 0);
  if (present && node->second.tree != nullptr) {
    TextFormat::ParseLocation where = node->second.tree->GetLocation(descriptor, index);
    if (where.line >= 0) {
      return path_ + ":" + position_text(where);
    }
  }
  return path_ + ":" + node->second.position;
}

void TextFile::fail(const Message& message, std::string_view field, int index, std::string_view what) const {
  std::string field_path = message.GetDescriptor()->name() + "." + std::string(field);
  if (index >= 0) {
    field_path += "[" + std::to_string(index) + "]";
  }
  throw std::invalid_argument(location(message, field, index) + ": " + field_path + ": " + std::string(what));
}

}  // namespace doppel::proto
