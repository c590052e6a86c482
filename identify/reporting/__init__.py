"""Text, JSON, HTML and plots of the results it is handed: results may call it, it imports
none of them."""
